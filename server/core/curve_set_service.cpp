// CurveSetServiceCore: conversion, validation naming field and limit, repo calls, drive calls,
// audit.
#include "server/core/curve_set_service.h"

#include <cmath>
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
#include "server/core/page_token.h"

namespace drivegw::server {
namespace {

using LM = LinMotParametricCurve;

constexpr absl::string_view kSetPrefix = "curveSets/";
// A curve of 10000 points over the limits everywhere would give 30000 lines; the first ones name
// the problem, the count says how big it is.
constexpr size_t kMaxViolations = 100;
constexpr double kDefaultStartToleranceMm = 0.1;  // CurveRunOptions (decision 013)

std::string SetResource(const std::string& id) { return absl::StrCat(std::string(kSetPrefix), id); }

// A stale etag (FailedPrecondition from the repo) gets a google.rpc.PreconditionFailure
// {type "ETAG"}: the REST front end answers it 412 (RFC 9110 §13.1.1 If-Match), as for parameter
// sets (decision 011).
absl::Status EtagDetail(absl::Status s, const std::string& set) {
  if (!absl::IsFailedPrecondition(s) || !absl::StrContains(s.message(), "etag")) return s;
  google::rpc::PreconditionFailure pf;
  auto* v = pf.add_violations();
  v->set_type("ETAG");
  v->set_subject(SetResource(set));
  v->set_description(std::string(s.message()));
  s.SetPayload("type.googleapis.com/google.rpc.PreconditionFailure",
               absl::Cord(pf.SerializeAsString()));
  return s;
}

// {"before": ..., "after": ...} for the audit entry (either may be absent).
std::string BeforeAfter(const v1::CurveSet* before, const v1::CurveSet* after) {
  std::string out = "{";
  if (before != nullptr) absl::StrAppend(&out, "\"before\":", ToAuditJson(*before));
  if (after != nullptr) {
    absl::StrAppend(&out, before != nullptr ? "," : "", "\"after\":", ToAuditJson(*after));
  }
  return out + "}";
}

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
  if (name.empty()) return FieldError(field, "is required (\"curveSets/{set}\")");
  absl::string_view id = name;
  if (absl::StartsWith(id, kSetPrefix)) id.remove_prefix(kSetPrefix.size());
  if (id.empty() || absl::StrContains(id, '/')) {
    return FieldError(field,
                      absl::StrCat("'", name, "' is not a curve set name (\"curveSets/{set}\")"));
  }
  return std::string(id);
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

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::CreateCurveSet(const v1::CreateCurveSetRequest& r,
                                                                 const CallContext& c) {
  auto fail = [&](absl::Status s) {
    WriteAudit(audit_, c, "", "CreateCurveSet", ToAuditJson(r), s);
    return s;
  };
  auto name = CurveSetId("curve_set.name", r.curve_set().name());
  if (!name.ok()) return fail(name.status());
  CurveSet set;
  set.name = *name;
  set.description = r.curve_set().description();
  for (int i = 0; i < r.curve_set().curves_size(); ++i) {
    auto curve = CurveFromProto(absl::StrCat("curve_set.curves[", i, "]"), r.curve_set().curves(i));
    if (!curve.ok()) return fail(curve.status());
    set.curves.push_back(*std::move(curve));
  }
  if (auto s = ViolationsStatus(CurveSetViolations(set.curves, nullptr, "curve_set."),
                                absl::StatusCode::kInvalidArgument);
      !s.ok()) {
    return fail(s);
  }
  auto stored = repo_.Create(set, c.principal, r.comment());
  if (!stored.ok()) return fail(stored.status());
  v1::CurveSet out = CurveSetToProto(*stored);
  WriteAudit(audit_, c, "", "CreateCurveSet", BeforeAfter(nullptr, &out), absl::OkStatus());
  return out;
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
  if (r.page_size() < 0 || r.page_size() > storage::CurveSetQuery::kMaxLimit) {
    return FieldError("page_size", absl::StrCat(r.page_size(), " is outside 0..",
                                                storage::CurveSetQuery::kMaxLimit));
  }
  const int limit = r.page_size() == 0 ? 100 : r.page_size();
  storage::CurveSetQuery q;
  auto after = SetPageToken(r.page_token());
  if (!after.ok()) return after.status();
  q.after_name = *std::move(after);
  // One more than asked for tells whether a next page exists.
  q.limit = std::min(limit + 1, storage::CurveSetQuery::kMaxLimit);
  auto sets = repo_.List(q);
  if (!sets.ok()) return sets.status();
  v1::ListCurveSetsResponse out;
  for (size_t i = 0; i < sets->size() && static_cast<int>(i) < limit; ++i) {
    *out.add_curve_sets() = CurveSetToProto((*sets)[i]);
  }
  if (static_cast<int>(sets->size()) > limit) {
    out.set_next_page_token((*sets)[static_cast<size_t>(limit) - 1].set.name);
  }
  return out;
}

absl::StatusOr<v1::CurveSet> CurveSetServiceCore::UpdateCurveSet(const v1::UpdateCurveSetRequest& r,
                                                                 const CallContext& c) {
  auto fail = [&](absl::Status s) {
    WriteAudit(audit_, c, "", "UpdateCurveSet", ToAuditJson(r), s);
    return s;
  };
  auto name = CurveSetId("curve_set.name", r.curve_set().name());
  if (!name.ok()) return fail(name.status());
  if (r.etag().empty()) return fail(FieldError("etag", "is required (updates are conditional)"));
  CurveSet set;
  set.name = *name;
  set.description = r.curve_set().description();
  for (int i = 0; i < r.curve_set().curves_size(); ++i) {
    auto curve = CurveFromProto(absl::StrCat("curve_set.curves[", i, "]"), r.curve_set().curves(i));
    if (!curve.ok()) return fail(curve.status());
    set.curves.push_back(*std::move(curve));
  }
  if (auto s = ViolationsStatus(CurveSetViolations(set.curves, nullptr, "curve_set."),
                                absl::StatusCode::kInvalidArgument);
      !s.ok()) {
    return fail(s);
  }
  auto before = repo_.Get(*name);
  if (!before.ok()) return fail(before.status());
  auto stored = repo_.Update(set, r.etag(), c.principal, r.comment());
  if (!stored.ok()) return fail(EtagDetail(stored.status(), *name));
  const v1::CurveSet b = CurveSetToProto(*before);
  v1::CurveSet out = CurveSetToProto(*stored);
  WriteAudit(audit_, c, "", "UpdateCurveSet", BeforeAfter(&b, &out), absl::OkStatus());
  return out;
}

absl::StatusOr<v1::DeleteCurveSetResponse> CurveSetServiceCore::DeleteCurveSet(
    const v1::DeleteCurveSetRequest& r, const CallContext& c) {
  auto name = CurveSetId("name", r.name());
  absl::Status s = name.status();
  std::string json = ToAuditJson(r);
  if (s.ok() && r.etag().empty()) s = FieldError("etag", "is required (deletes are conditional)");
  if (s.ok()) {
    auto before = repo_.Get(*name);
    if (before.ok()) {
      const v1::CurveSet b = CurveSetToProto(*before);
      json = BeforeAfter(&b, nullptr);
    }
    s = EtagDetail(repo_.Delete(*name, r.etag()), *name);
  }
  WriteAudit(audit_, c, "", "DeleteCurveSet", json, s);
  if (!s.ok()) return s;
  return v1::DeleteCurveSetResponse();
}

absl::StatusOr<v1::ListCurveSetVersionsResponse> CurveSetServiceCore::ListCurveSetVersions(
    const v1::ListCurveSetVersionsRequest& r, const CallContext&) {
  auto name = CurveSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto versions = repo_.ListVersions(*name);
  if (!versions.ok()) return versions.status();
  v1::ListCurveSetVersionsResponse out;
  for (const auto& v : *versions) *out.add_versions() = CurveSetVersionToProto(*name, v);
  return out;
}

absl::StatusOr<v1::CurveSetVersion> CurveSetServiceCore::GetCurveSetVersion(
    const v1::GetCurveSetVersionRequest& r, const CallContext&) {
  auto name = CurveSetId("name", r.name());
  if (!name.ok()) return name.status();
  if (r.version() < 1) return FieldError("version", absl::StrCat(r.version(), " is below 1"));
  auto v = repo_.GetVersion(*name, r.version());
  if (!v.ok()) return v.status();
  return CurveSetVersionToProto(*name, *v);
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
  plot->set_name(SetResource(*name));
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
  AuditObject entry;
  CurveTarget t;
  auto audit = [&](const absl::Status& s) {
    WriteAudit(audit_, c, t.drive_name, "DownloadCurve", entry.With("request", ToAuditJson(r)), s);
  };
  auto done = [&](absl::Status s) {
    audit(s);
    return s;
  };
  absl::Status resolved = ResolveTarget(r.drive(), r.name(), r.curve(), r.version(), c, &t);
  if (t.version != 0) {
    entry.Str("set", SetResource(t.set)).Num("version", t.version).Str("curve", t.curve.name);
  }
  if (!resolved.ok()) return done(resolved);
  Drive& d = *t.drive;
  const Curve* curve = &t.curve;
  int id = r.linmot_curve_id();
  if (const auto* lm = std::get_if<LM>(&curve->shape)) {
    if (id != 0 && id != lm->curve_id) {
      return done(
          FieldError("linmot_curve_id",
                     absl::StrCat(id, ": curve '", curve->name, "' is a LinMot curve with ID ",
                                  lm->curve_id, " (give 0 or ", lm->curve_id, ")")));
    }
    id = lm->curve_id;
  } else if (id < LM::kMinCurveId || id > LM::kMaxCurveId) {
    return done(
        FieldError("linmot_curve_id",
                   absl::StrCat(id, " is outside ", LM::kMinCurveId, "..", LM::kMaxCurveId,
                                " (required for a position/time curve; linmot-mc.md §7 L997)")));
  }
  auto wire = ToLinMotCurve(*curve, id);
  if (!wire.ok()) return done(FieldError("curve", std::string(wire.status().message())));
  const std::string hash = LinMotCurveHash(*wire);
  entry.Num("curve_id", wire->curve_id)
      .Num("points", static_cast<double>(wire->points.size()))
      .Str("hash", hash);
  // A download writes the drive's curve memory like WriteParameter does: refused while DOWN, last
  // before the family, so a request that can never be valid is named as such first (decision 1491).
  if (auto down = RefuseIfDown(d, "DownloadCurve"); !down.ok()) return done(down);
  absl::Status s = MapUnsupported(d.DownloadCurve(*wire), d, "DownloadCurve",
                                  "curves are stored on LinMot drives only; RunCurve runs them "
                                  "on every family");
  if (!s.ok()) return done(s);
  audit(s);
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
  AuditObject entry;
  CurveTarget t;
  auto audit = [&](const absl::Status& s) {
    WriteAudit(audit_, c, t.drive_name, "RunCurve", entry.With("request", ToAuditJson(r)), s);
  };
  auto done = [&](absl::Status s) {
    audit(s);
    return s;
  };
  absl::Status resolved = ResolveTarget(r.drive(), r.name(), r.curve(), r.version(), c, &t);
  if (t.version != 0) {
    entry.Str("set", SetResource(t.set)).Num("version", t.version).Str("curve", t.curve.name);
  }
  if (!resolved.ok()) return done(resolved);
  Drive& d = *t.drive;
  const Curve* curve = &t.curve;
  CurveRunOptions options;
  options.start_tolerance_mm = r.start_tolerance_mm();
  if (!std::isfinite(options.start_tolerance_mm) || options.start_tolerance_mm < 0) {
    return done(FieldError("start_tolerance_mm",
                           absl::StrCat(r.start_tolerance_mm(), " is not a finite value >= 0")));
  }
  if (options.start_tolerance_mm == 0) options.start_tolerance_mm = kDefaultStartToleranceMm;
  options.linmot_scratch_curve_id = r.linmot_scratch_curve_id();
  if (options.linmot_scratch_curve_id == 0) options.linmot_scratch_curve_id = LM::kMaxCurveId;
  if (options.linmot_scratch_curve_id < LM::kMinCurveId ||
      options.linmot_scratch_curve_id > LM::kMaxCurveId) {
    return done(
        FieldError("linmot_scratch_curve_id",
                   absl::StrCat(r.linmot_scratch_curve_id(), " is outside ", LM::kMinCurveId, "..",
                                LM::kMaxCurveId, " (linmot-mc.md §7 L997)")));
  }
  if (auto sum = SummarizeCurve(*curve); sum.ok()) entry.Num("duration_s", sum->duration_s);
  // A curve run moves the axis: refused while DOWN like every move (decision 1491).
  if (auto down = RefuseIfDown(d, "RunCurve"); !down.ok()) return done(down);
  auto info = d.RunCurve(*curve, options);
  if (!info.ok()) {
    return done(MapUnsupported(info.status(), d, "RunCurve",
                               "its family has no curve runner in this build"));
  }
  v1::CommandHandle out = ToProto(d.config().name, *info);
  entry.Str("command", out.name());
  audit(absl::OkStatus());
  return out;
}

}  // namespace drivegw::server
