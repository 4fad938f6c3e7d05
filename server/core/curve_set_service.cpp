// CurveSetServiceCore: conversion, validation naming field and limit, repo calls, drive calls,
// audit.
#include "server/core/curve_set_service.h"

#include <cmath>
#include <optional>
#include <set>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "adapters/core/curve_run.h"
#include "adapters/core/status.h"
#include "google/protobuf/struct.pb.h"
#include "google/rpc/error_details.pb.h"
#include "server/core/audit.h"
#include "server/core/convert.h"
#include "server/core/curve_set_io.h"
#include "server/core/drive_service.h"
#include "server/core/errors.h"
#include "server/core/set_service_common.h"

namespace drivegw::server {
namespace {

using LM = LinMotParametricCurve;

constexpr absl::string_view kSetPrefix = "curveSets/";
// A curve of 10000 points over the limits everywhere would give 30000 lines; the first ones name
// the problem, the count says how big it is.
constexpr size_t kMaxViolations = 100;
constexpr double kDefaultStartToleranceMm = 0.1;  // CurveRunOptions (decision 013)

// A family without the operation answers Unimplemented at the Drive seam (decision 013). The
// call itself exists, the target drive cannot do it: FailedPrecondition (pick another drive),
// naming drive, family and what to use instead, with a google.rpc.ErrorInfo for programs.
absl::Status MapUnsupported(absl::Status s, const Drive& d, const std::string& operation,
                            const std::string& hint) {
  if (!absl::IsUnimplemented(s)) return s;
  absl::Status out = absl::FailedPreconditionError(absl::StrCat(
      "drive: drives/", d.config().name, " (family ", d.config().family, ") does not support ",
      operation, hint.empty() ? "" : "; ", hint, " (", s.message(), ")"));
  return WithErrorInfo(
      std::move(out), "CURVE_OPERATION_UNSUPPORTED",
      {{"drive", d.config().name}, {"family", d.config().family}, {"operation", operation}});
}

// Violations of one curve at `index` of its set.
void AppendCurveViolations(size_t index, const Curve& curve, const AxisConfig* axis,
                           const std::string& prefix, std::vector<v1::CurveViolation>& out,
                           size_t& total) {
  const std::vector<std::string> errors =
      axis != nullptr ? CurveErrors(curve, *axis) : CurveShapeErrors(curve);
  const std::string label = absl::StrCat("curves[", index, "] '", curve.name, "': ");
  for (const std::string& e : errors) {
    ++total;
    if (out.size() >= kMaxViolations) continue;
    // Every curve error starts with its sub-field ("points[17]: ...", "time_step_s: ...").
    const size_t colon = e.find(": ");
    v1::CurveViolation v;
    v.set_curve(curve.name);
    v.set_field(absl::StrCat(prefix, "curves[", index, "]", colon == std::string::npos ? "" : ".",
                             colon == std::string::npos ? "" : e.substr(0, colon)));
    v.set_description(absl::StrCat(label, e));
    out.push_back(std::move(v));
  }
}

// A small JSON object for audit entries (strings escaped by the protobuf printer).
class AuditObject {
 public:
  AuditObject& Str(const std::string& key, const std::string& v) {
    (*s_.mutable_fields())[key].set_string_value(v);
    return *this;
  }
  AuditObject& Num(const std::string& key, double v) {
    (*s_.mutable_fields())[key].set_number_value(v);
    return *this;
  }
  // `json` is an object printed by ToAuditJson; kept as a string field would double-escape it,
  // so the whole entry is assembled as text.
  std::string With(const std::string& key, const std::string& json) const {
    std::string body = ToAuditJson(s_);
    if (body.size() < 2) body = "{}";
    body.pop_back();  // '}'
    return absl::StrCat(body, body.size() > 1 ? "," : "", "\"", key, "\":", json, "}");
  }

 private:
  google::protobuf::Struct s_;
};

// The one audit entry of a DownloadCurve or RunCurve call: the request, what the call resolved
// (set, version, curve) and did, under the drive's name as far as it was found (`drive` follows
// the call's CurveTarget).
class CurveCallAudit {
 public:
  CurveCallAudit(storage::AuditLog* log, const CallContext& c, const char* action,
                 const google::protobuf::Message& request, const std::string& drive)
      : log_(log), c_(c), action_(action), request_(request), drive_(drive) {}

  AuditObject& entry() { return entry_; }
  // Names the set, version and curve once the curve was found (version != 0).
  void Target(const std::string& set, int version, const std::string& curve) {
    if (version == 0) return;
    entry_.Str("set", SetResource(kSetPrefix, set)).Num("version", version).Str("curve", curve);
  }
  void Write(const absl::Status& s) const {
    WriteAudit(log_, c_, drive_, action_, entry_.With("request", ToAuditJson(request_)), s);
  }
  absl::Status Fail(absl::Status s) const {
    Write(s);
    return s;
  }

 private:
  storage::AuditLog* const log_;
  const CallContext& c_;
  const char* const action_;
  const google::protobuf::Message& request_;
  const std::string& drive_;
  AuditObject entry_;
};

// The violations of the curve at `index` of its set against `axis`, capped like a set's.
std::vector<v1::CurveViolation> CurveViolationsAt(size_t index, const Curve& curve,
                                                  const AxisConfig& axis) {
  std::vector<v1::CurveViolation> out;
  size_t total = 0;
  AppendCurveViolations(index, curve, &axis, "", out, total);
  if (total > out.size()) {
    v1::CurveViolation more;
    more.set_curve(curve.name);
    more.set_field(absl::StrCat("curves[", index, "]"));
    more.set_description(absl::StrCat("(and ", total - out.size(), " more violations)"));
    out.push_back(std::move(more));
  }
  return out;
}

}  // namespace

absl::StatusOr<std::string> CurveSetId(const std::string& field, const std::string& name) {
  return SetIdFromName(field, name, kSetPrefix, "curve set");
}

std::vector<v1::CurveViolation> CurveSetViolations(const std::vector<Curve>& curves,
                                                   const AxisConfig* axis,
                                                   const std::string& field_prefix) {
  std::vector<v1::CurveViolation> out;
  size_t total = 0;
  std::set<std::string> names;
  std::set<int> ids;
  for (size_t i = 0; i < curves.size(); ++i) {
    const Curve& c = curves[i];
    const std::string label = absl::StrCat("curves[", i, "] '", c.name, "': ");
    auto add = [&](const std::string& sub, const std::string& what) {
      ++total;
      if (out.size() >= kMaxViolations) return;
      v1::CurveViolation v;
      v.set_curve(c.name);
      v.set_field(absl::StrCat(field_prefix, "curves[", i, "].", sub));
      v.set_description(absl::StrCat(label, sub, ": ", what));
      out.push_back(std::move(v));
    };
    if (!names.insert(c.name).second) add("name", "listed twice in the set");
    // A LinMot drive holds one curve per ID (linmot-mc.md §7 L997; decision 012).
    if (const auto* lm = std::get_if<LM>(&c.shape); lm && !ids.insert(lm->curve_id).second) {
      add("curve_id", absl::StrCat(lm->curve_id, " is used by another curve of the set"));
    }
    AppendCurveViolations(i, c, axis, field_prefix, out, total);
  }
  if (total > out.size()) {
    v1::CurveViolation more;
    more.set_field(absl::StrCat(field_prefix, "curves"));
    more.set_description(absl::StrCat("(and ", total - out.size(), " more violations)"));
    out.push_back(std::move(more));
  }
  return out;
}

absl::Status ViolationsStatus(const std::vector<v1::CurveViolation>& violations,
                              absl::StatusCode code) {
  if (violations.empty()) return absl::OkStatus();
  google::rpc::BadRequest br;
  for (const auto& v : violations) {
    auto* fv = br.add_field_violations();
    fv->set_field(v.field());
    fv->set_description(v.description());
  }
  std::string message = violations.front().description();
  if (violations.size() > 1) absl::StrAppend(&message, " (and ", violations.size() - 1, " more)");
  absl::Status s(code, message);
  s.SetPayload(absl::string_view(kBadRequestUrl.data(), kBadRequestUrl.size()),
               absl::Cord(br.SerializeAsString()));
  return s;
}

namespace {

// The set a Create or Update request carries, named `name`, its shape checked (no axis yet):
// errors name the "curve_set.curves[i]..." field.
absl::StatusOr<CurveSet> RequestedCurveSet(const std::string& name, const v1::CurveSet& in) {
  CurveSet set;
  set.name = name;
  set.description = in.description();
  for (int i = 0; i < in.curves_size(); ++i) {
    auto curve = CurveFromProto(absl::StrCat("curve_set.curves[", i, "]"), in.curves(i));
    if (!curve.ok()) return curve.status();
    set.curves.push_back(*std::move(curve));
  }
  DGW_RETURN_IF_ERROR(ViolationsStatus(CurveSetViolations(set.curves, nullptr, "curve_set."),
                                       absl::StatusCode::kInvalidArgument));
  return set;
}

}  // namespace

CurveSetServiceCore::CurveSetServiceCore(storage::CurveSetRepo& repo,
                                         std::vector<std::shared_ptr<Drive>> drives,
                                         storage::AuditLog* audit, const LeaseManager* leases)
    : repo_(repo), drives_(std::move(drives)), audit_(audit), leases_(leases) {
  for (const auto& d : drives_) by_name_[d->config().name] = d.get();
}

absl::StatusOr<Drive*> CurveSetServiceCore::FindDrive(const std::string& field,
                                                      const std::string& name) const {
  if (name.empty()) return FieldError(field, "is required (\"drives/{drive}\")");
  absl::string_view id = name;
  if (absl::StartsWith(id, "drives/")) id.remove_prefix(7);
  if (id.empty() || absl::StrContains(id, '/')) {
    return FieldError(field, absl::StrCat("'", name, "' is not a drive name (\"drives/{drive}\")"));
  }
  auto it = by_name_.find(std::string(id));
  if (it == by_name_.end()) {
    return absl::NotFoundError(absl::StrCat(field, ": drives/", id, " is not configured"));
  }
  return it->second;
}

absl::StatusOr<std::vector<Curve>> CurveSetServiceCore::CurvesAt(const std::string& name,
                                                                 int version, int* version_out) {
  if (version < 0) return FieldError("version", absl::StrCat(version, " is below 0"));
  if (version == 0) {
    auto set = repo_.Get(name);
    if (!set.ok()) return set.status();
    *version_out = set->version;
    return std::move(set->set.curves);
  }
  auto v = repo_.GetVersion(name, version);
  if (!v.ok()) return v.status();
  *version_out = v->version;
  return std::move(v->curves);
}

absl::StatusOr<Curve> CurveSetServiceCore::CurveAt(const std::string& name,
                                                   const std::string& curve, int version,
                                                   int* version_out, size_t* index_out) {
  if (curve.empty()) return FieldError("curve", "is required (a curve's name in the set)");
  auto curves = CurvesAt(name, version, version_out);
  if (!curves.ok()) return curves.status();
  std::string known;
  for (size_t i = 0; i < curves->size(); ++i) {
    Curve& c = (*curves)[i];
    if (c.name == curve) {
      *index_out = i;
      return std::move(c);
    }
    absl::StrAppend(&known, known.empty() ? "" : ", ", "'", c.name, "'");
  }
  return absl::NotFoundError(absl::StrCat("curve: curve set '", name, "' version ", *version_out,
                                          " has no curve '", curve,
                                          "' (curves: ", known.empty() ? "none" : known, ")"));
}

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::StoreCurveSet(
    const char* action, const google::protobuf::Message& request, const v1::CurveSet& in,
    bool update, const std::string& etag, const std::string& comment, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    WriteAudit(audit_, c, "", action, ToAuditJson(request), s);
    return s;
  };
  auto name = CurveSetId("curve_set.name", in.name());
  if (!name.ok()) return fail(name.status());
  if (update && etag.empty()) {
    return fail(FieldError("etag", "is required (updates are conditional)"));
  }
  auto set = RequestedCurveSet(*name, in);
  if (!set.ok()) return fail(set.status());
  std::optional<v1::CurveSet> before;
  absl::StatusOr<storage::StoredCurveSet> stored;
  if (update) {
    auto old = repo_.Get(*name);
    if (!old.ok()) return fail(old.status());
    before = CurveSetToProto(*old);
    stored = repo_.Update(*set, etag, c.principal, comment);
    if (!stored.ok()) return fail(EtagDetail(stored.status(), SetResource(kSetPrefix, *name)));
  } else {
    stored = repo_.Create(*set, c.principal, comment);
    if (!stored.ok()) return fail(stored.status());
  }
  v1::CurveSet out = CurveSetToProto(*stored);
  WriteAudit(audit_, c, "", action, BeforeAfterJson(before ? &*before : nullptr, &out),
             absl::OkStatus());
  return out;
}

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::CreateCurveSet(const v1::CreateCurveSetRequest& r,
                                                                 const CallContext& c) {
  return StoreCurveSet("CreateCurveSet", r, r.curve_set(), false, "", r.comment(), c);
}

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::GetCurveSet(const v1::GetCurveSetRequest& r,
                                                              const CallContext&) {
  auto name = CurveSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto set = repo_.Get(*name);
  if (!set.ok()) return set.status();
  return CurveSetToProto(*set);
}

absl::StatusOr<v1::ListCurveSetsResponse> CurveSetServiceCore::ListCurveSets(
    const v1::ListCurveSetsRequest& r, const CallContext&) {
  auto page = SetPageOf(r.page_size(), r.page_token(), storage::CurveSetQuery::kMaxLimit);
  if (!page.ok()) return page.status();
  storage::CurveSetQuery q;
  q.after_name = page->after_name;
  q.limit = page->query_limit;
  auto sets = repo_.List(q);
  if (!sets.ok()) return sets.status();
  v1::ListCurveSetsResponse out;
  out.set_next_page_token(EmitPage(
      *sets, *page, [&](const auto& set) { *out.add_curve_sets() = CurveSetToProto(set); },
      [](const auto& set) { return set.set.name; }));
  return out;
}

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::UpdateCurveSet(const v1::UpdateCurveSetRequest& r,
                                                                 const CallContext& c) {
  return StoreCurveSet("UpdateCurveSet", r, r.curve_set(), true, r.etag(), r.comment(), c);
}

absl::StatusOr<v1::DeleteCurveSetResponse> CurveSetServiceCore::DeleteCurveSet(
    const v1::DeleteCurveSetRequest& r, const CallContext& c) {
  std::string json = ToAuditJson(r);
  const absl::Status s =
      DeleteSet(repo_, CurveSetId("name", r.name()), r.etag(), kSetPrefix, CurveSetToProto, json);
  WriteAudit(audit_, c, "", "DeleteCurveSet", json, s);
  if (!s.ok()) return s;
  return v1::DeleteCurveSetResponse();
}

absl::StatusOr<v1::ListCurveSetVersionsResponse> CurveSetServiceCore::ListCurveSetVersions(
    const v1::ListCurveSetVersionsRequest& r, const CallContext&) {
  return ListSetVersions<v1::ListCurveSetVersionsResponse>(repo_, CurveSetId("name", r.name()),
                                                           CurveSetVersionToProto);
}

absl::StatusOr<v1::CurveSetVersion> CurveSetServiceCore::GetCurveSetVersion(
    const v1::GetCurveSetVersionRequest& r, const CallContext&) {
  return GetSetVersion(repo_, CurveSetId("name", r.name()), r.version(), CurveSetVersionToProto);
}

absl::StatusOr<v1::CurvePlot> CurveSetServiceCore::GetCurvePlot(const v1::GetCurvePlotRequest& r,
                                                                const CallContext&) {
  auto name = CurveSetId("name", r.name());
  if (!name.ok()) return name.status();
  int version = 0;
  size_t index = 0;
  auto curve = CurveAt(*name, r.curve(), r.version(), &version, &index);
  if (!curve.ok()) return curve.status();
  auto plot = CurvePlotOf(*curve);
  // Stored curves passed ValidateCurveSetShape; a failure here is a stored value we cannot use.
  if (!plot.ok()) {
    return absl::DataLossError(absl::StrCat("curve set '", *name, "' version ", version, " curve '",
                                            r.curve(), "': ", plot.status().message()));
  }
  plot->set_name(SetResource(kSetPrefix, *name));
  plot->set_version(version);
  return plot;
}

absl::StatusOr<v1::ValidateCurveSetResponse> CurveSetServiceCore::ValidateCurveSet(
    const v1::ValidateCurveSetRequest& r, const CallContext&) {
  auto name = CurveSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto drive = FindDrive("drive", r.drive());
  if (!drive.ok()) return drive.status();
  int version = 0;
  auto curves = CurvesAt(*name, r.version(), &version);
  if (!curves.ok()) return curves.status();
  const AxisConfig& axis = (*drive)->config().axis;
  v1::ValidateCurveSetResponse out;
  *out.mutable_axis() = ToProto(axis);
  for (auto& v : CurveSetViolations(*curves, &axis, "")) *out.add_violations() = std::move(v);
  out.set_valid(out.violations().empty());
  return out;
}

absl::Status CurveSetServiceCore::ResolveTarget(const std::string& drive, const std::string& set,
                                                const std::string& curve, int version,
                                                const CallContext& c, CurveTarget* target) {
  target->drive_name = drive;
  DGW_ASSIGN_OR_RETURN(target->drive, FindDrive("drive", drive));
  target->drive_name = target->drive->config().name;
  DGW_RETURN_IF_ERROR(CheckLease(leases_, target->drive_name, c));  // decision 019
  DGW_ASSIGN_OR_RETURN(target->set, CurveSetId("name", set));
  DGW_ASSIGN_OR_RETURN(target->curve,
                       CurveAt(target->set, curve, version, &target->version, &target->index));
  return ViolationsStatus(
      CurveViolationsAt(target->index, target->curve, target->drive->config().axis),
      absl::StatusCode::kOutOfRange);
}

absl::StatusOr<v1::DownloadCurveResponse> CurveSetServiceCore::DownloadCurve(
    const v1::DownloadCurveRequest& r, const CallContext& c) {
  CurveTarget t;
  CurveCallAudit audit(audit_, c, "DownloadCurve", r, t.drive_name);
  absl::Status resolved = ResolveTarget(r.drive(), r.name(), r.curve(), r.version(), c, &t);
  audit.Target(t.set, t.version, t.curve.name);
  if (!resolved.ok()) return audit.Fail(resolved);
  Drive& d = *t.drive;
  const Curve* curve = &t.curve;
  int id = r.linmot_curve_id();
  if (const auto* lm = std::get_if<LM>(&curve->shape)) {
    if (id != 0 && id != lm->curve_id) {
      return audit.Fail(
          FieldError("linmot_curve_id",
                     absl::StrCat(id, ": curve '", curve->name, "' is a LinMot curve with ID ",
                                  lm->curve_id, " (give 0 or ", lm->curve_id, ")")));
    }
    id = lm->curve_id;
  } else if (id < LM::kMinCurveId || id > LM::kMaxCurveId) {
    return audit.Fail(
        FieldError("linmot_curve_id",
                   absl::StrCat(id, " is outside ", LM::kMinCurveId, "..", LM::kMaxCurveId,
                                " (required for a position/time curve; linmot-mc.md §7 L997)")));
  }
  auto wire = ToLinMotCurve(*curve, id);
  if (!wire.ok()) return audit.Fail(FieldError("curve", std::string(wire.status().message())));
  const std::string hash = LinMotCurveHash(*wire);
  audit.entry()
      .Num("curve_id", wire->curve_id)
      .Num("points", static_cast<double>(wire->points.size()))
      .Str("hash", hash);
  // A download writes the drive's curve memory like WriteParameter does: refused while DOWN, last
  // before the family, so a request that can never be valid is named as such first (decision 1491).
  if (auto down = RefuseIfDown(d, "DownloadCurve"); !down.ok()) return audit.Fail(down);
  absl::Status s = MapUnsupported(d.DownloadCurve(*wire), d, "DownloadCurve",
                                  "curves are stored on LinMot drives only; RunCurve runs them "
                                  "on every family");
  if (!s.ok()) return audit.Fail(s);
  audit.Write(s);
  v1::DownloadCurveResponse out;
  out.set_drive(DriveResourceName(d.config().name));
  out.set_curve_id(wire->curve_id);
  out.set_point_count(static_cast<int32_t>(wire->points.size()));
  out.set_x_length_s(wire->x_length_s);
  out.set_hash(hash);
  return out;
}

absl::StatusOr<v1::CommandHandle> CurveSetServiceCore::RunCurve(const v1::RunCurveRequest& r,
                                                                const CallContext& c) {
  CurveTarget t;
  CurveCallAudit audit(audit_, c, "RunCurve", r, t.drive_name);
  absl::Status resolved = ResolveTarget(r.drive(), r.name(), r.curve(), r.version(), c, &t);
  audit.Target(t.set, t.version, t.curve.name);
  if (!resolved.ok()) return audit.Fail(resolved);
  Drive& d = *t.drive;
  const Curve* curve = &t.curve;
  CurveRunOptions options;
  options.start_tolerance_mm = r.start_tolerance_mm();
  if (!std::isfinite(options.start_tolerance_mm) || options.start_tolerance_mm < 0) {
    return audit.Fail(FieldError(
        "start_tolerance_mm", absl::StrCat(r.start_tolerance_mm(), " is not a finite value >= 0")));
  }
  if (options.start_tolerance_mm == 0) options.start_tolerance_mm = kDefaultStartToleranceMm;
  options.linmot_scratch_curve_id = r.linmot_scratch_curve_id();
  if (options.linmot_scratch_curve_id == 0) options.linmot_scratch_curve_id = LM::kMaxCurveId;
  if (options.linmot_scratch_curve_id < LM::kMinCurveId ||
      options.linmot_scratch_curve_id > LM::kMaxCurveId) {
    return audit.Fail(
        FieldError("linmot_scratch_curve_id",
                   absl::StrCat(r.linmot_scratch_curve_id(), " is outside ", LM::kMinCurveId, "..",
                                LM::kMaxCurveId, " (linmot-mc.md §7 L997)")));
  }
  if (auto sum = SummarizeCurve(*curve); sum.ok()) audit.entry().Num("duration_s", sum->duration_s);
  // A curve run moves the axis: refused while DOWN like every move (decision 1491).
  if (auto down = RefuseIfDown(d, "RunCurve"); !down.ok()) return audit.Fail(down);
  auto info = d.RunCurve(*curve, options);
  if (!info.ok()) {
    return audit.Fail(MapUnsupported(info.status(), d, "RunCurve",
                                     "its family has no curve runner in this build"));
  }
  v1::CommandHandle out = ToProto(d.config().name, *info);
  audit.entry().Str("command", out.name());
  audit.Write(absl::OkStatus());
  return out;
}

}  // namespace drivegw::server
