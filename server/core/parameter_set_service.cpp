// ParameterSetServiceCore: catalogue resolution, validation, repo calls, applier, audit.
#include "server/core/parameter_set_service.h"

#include <algorithm>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/time_util.h"
#include "google/rpc/error_details.pb.h"
#include "server/core/audit.h"
#include "server/core/errors.h"
#include "server/core/parameter_set_io.h"
#include "server/core/set_service_common.h"

namespace drivegw::server {
namespace {

using google::protobuf::util::TimeUtil;

constexpr absl::string_view kSetPrefix = "parameterSets/";
constexpr absl::string_view kOperationPrefix = "operations/";

google::protobuf::Timestamp ToProto(storage::Time t) {
  return TimeUtil::MillisecondsToTimestamp(
      std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count());
}

void ToProto(const std::vector<storage::ParameterValue>& in,
             google::protobuf::RepeatedPtrField<v1::ParameterValue>* out) {
  for (const auto& v : in) {
    auto* p = out->Add();
    p->set_parameter(v.parameter);
    p->set_id(v.id);
    p->set_value(v.value);
  }
}

v1::ParameterSet ToProto(const storage::ParameterSet& s) {
  v1::ParameterSet p;
  p.set_name(absl::StrCat(std::string(kSetPrefix), s.name));
  p.set_family(s.family);
  p.set_model(s.model);
  p.set_description(s.description);
  p.set_target_stored(s.target_stored);
  ToProto(s.values, p.mutable_parameters());
  p.set_version(s.version);
  p.set_etag(s.etag);
  p.set_author(s.author);
  *p.mutable_create_time() = ToProto(s.created_at);
  *p.mutable_update_time() = ToProto(s.updated_at);
  return p;
}

v1::ParameterSetVersion ToProto(const std::string& name, const storage::ParameterSetVersion& v) {
  v1::ParameterSetVersion p;
  p.set_name(absl::StrCat(std::string(kSetPrefix), name));
  p.set_version(v.version);
  ToProto(v.values, p.mutable_parameters());
  p.set_author(v.author);
  p.set_comment(v.comment);
  *p.mutable_create_time() = ToProto(v.created_at);
  return p;
}

// The version overload as a value for the shared version calls (set_service_common.h).
constexpr auto kVersionToProto =
    [](const std::string& name, const storage::ParameterSetVersion& v) { return ToProto(name, v); };

v1::Operation ToProto(const storage::ApplyOperation& op) {
  v1::Operation p;
  p.set_name(absl::StrCat(std::string(kOperationPrefix), op.id));
  p.set_state(op.state);
  p.set_done(op.state != "RUNNING" && !op.state.empty());
  p.set_parameter_set(absl::StrCat(std::string(kSetPrefix), op.set_name));
  p.set_version(op.set_version);
  p.set_dry_run(op.dry_run);
  for (const auto& d : op.drives) {
    auto* r = p.add_drives();
    r->set_drive(absl::StrCat("drives/", d.drive));
    r->set_state(d.state);
    ToProto(d.pre_image, r->mutable_pre_image());
    ToProto(d.written, r->mutable_written());
    r->set_failed_parameter(d.failed_parameter);
    r->set_error(d.error);
  }
  p.set_principal(op.principal);
  *p.mutable_create_time() = ToProto(op.created_at);
  *p.mutable_update_time() = ToProto(op.updated_at);
  p.set_target_stored(op.target_stored);
  if (!op.restores.empty())
    p.set_restores(absl::StrCat(std::string(kOperationPrefix), op.restores));
  return p;
}

// Drive states whose pre-image may differ from what the drive holds now (decision 1441).
bool HasValuesToRestore(const storage::ApplyDriveResult& d) {
  return !d.pre_image.empty() && (d.state == "APPLYING" || d.state == "INTERRUPTED" ||
                                  d.state == "APPLIED" || d.state == "ROLLBACK_FAILED");
}

// "operations/op-7" or "op-7" -> "op-7"; InvalidArgument naming `field` otherwise.
absl::StatusOr<std::string> OperationId(const std::string& field, const std::string& name) {
  absl::string_view id = name;
  if (absl::StartsWith(id, kOperationPrefix)) id.remove_prefix(kOperationPrefix.size());
  if (id.empty() || absl::StrContains(id, '/')) {
    return FieldError(field,
                      absl::StrCat("'", name, "' is not an operation name (\"operations/{op}\")"));
  }
  return std::string(id);
}

std::vector<storage::ParameterValue> FromProto(
    const google::protobuf::RepeatedPtrField<v1::ParameterValue>& in) {
  std::vector<storage::ParameterValue> out;
  out.reserve(in.size());
  for (const auto& v : in) out.push_back(storage::ParameterValue{v.parameter(), v.id(), v.value()});
  return out;
}

}  // namespace

absl::StatusOr<std::string> ParameterSetId(const std::string& field, const std::string& name) {
  return SetIdFromName(field, name, kSetPrefix, "parameter set");
}

ParameterSetServiceCore::ParameterSetServiceCore(storage::ParameterSetRepo& repo,
                                                 ParameterApplier& applier,
                                                 const CatalogueList& catalogues,
                                                 std::vector<std::shared_ptr<Drive>> drives,
                                                 storage::AuditLog* audit,
                                                 const LeaseManager* leases)
    : repo_(repo),
      applier_(applier),
      catalogues_(catalogues),
      drives_(std::move(drives)),
      audit_(audit),
      leases_(leases) {
  for (const auto& d : drives_) by_name_[d->config().name] = d.get();
}

void ParameterSetServiceCore::Audit(const CallContext& c, const std::string& drive,
                                    const std::string& action, const std::string& json,
                                    const absl::Status& result) {
  WriteAudit(audit_, c, drive, action, json, result);
}

absl::StatusOr<const ParameterCatalogue*> ParameterSetServiceCore::Catalogue(
    const std::string& field, const std::string& family) const {
  if (family.empty()) return FieldError(field, "is required (a drive family)");
  std::string known;
  for (const auto& cat : catalogues_) {
    if (cat->family() == family) return cat.get();
    absl::StrAppend(&known, known.empty() ? "" : ", ", cat->family());
  }
  return FieldError(field, absl::StrCat("unknown family '", family, "' (known: ", known, ")"));
}

absl::Status ParameterSetServiceCore::Resolve(const std::string& field,
                                              const ParameterCatalogue& catalogue,
                                              std::vector<storage::ParameterValue>& values) const {
  std::set<uint32_t> seen;
  std::vector<FieldViolation> violations;
  for (size_t i = 0; i < values.size(); ++i) {
    auto& v = values[i];
    const std::string at = absl::StrCat(field, "[", i, "]");
    auto def = catalogue.Find(v.parameter);
    if (!def.ok()) {
      violations.push_back({absl::StrCat(at, ".parameter"), std::string(def.status().message())});
      continue;
    }
    if (!seen.insert(def->id).second) {
      violations.push_back(
          {absl::StrCat(at, ".parameter"), absl::StrCat(def->name, " is listed twice")});
      continue;
    }
    if (auto s = catalogue.Validate(*def, v.value); !s.ok()) {
      violations.push_back({absl::StrCat(at, ".value"), std::string(s.message())});
      continue;
    }
    v.parameter = def->name;
    v.id = def->id;
  }
  if (!violations.empty()) return FieldErrors(violations);
  return absl::OkStatus();
}

absl::StatusOr<Drive*> ParameterSetServiceCore::FindDrive(const std::string& field,
                                                          const std::string& name) const {
  if (name.empty()) return FieldError(field, "is required (\"drives/{drive}\")");
  absl::string_view id = name;
  if (absl::StartsWith(id, "drives/")) id.remove_prefix(7);
  auto it = by_name_.find(std::string(id));
  if (it == by_name_.end()) {
    return absl::NotFoundError(absl::StrCat(field, ": drives/", id, " is not configured"));
  }
  return it->second;
}

absl::StatusOr<storage::ParameterSet> ParameterSetServiceCore::SetAt(const std::string& name,
                                                                     int version,
                                                                     const char* version_field) {
  // A negative version is refused before the lookup: it is wrong whether the set exists or not.
  if (version < 0) return FieldError(version_field, absl::StrCat(version, " is below 0"));
  auto set = repo_.Get(name);
  if (!set.ok() || version == 0 || version == set->version) return set;
  auto v = repo_.GetVersion(name, version);
  if (!v.ok()) return v.status();
  set->version = v->version;
  set->values = v->values;
  set->author = v->author;
  return set;
}

absl::StatusOr<v1::ListParameterDefinitionsResponse>
ParameterSetServiceCore::ListParameterDefinitions(const v1::ListParameterDefinitionsRequest& r,
                                                  const CallContext&) {
  auto cat = Catalogue("family", r.family());
  if (!cat.ok()) return cat.status();
  const std::string filter = absl::AsciiStrToLower(r.filter());
  v1::ListParameterDefinitionsResponse out;
  for (const auto& d : (*cat)->Definitions()) {
    if (!filter.empty() && !absl::StrContains(absl::AsciiStrToLower(d.name), filter) &&
        !absl::StrContains(absl::AsciiStrToLower(d.title), filter)) {
      continue;
    }
    auto* p = out.add_definitions();
    p->set_id(d.id);
    p->set_name(d.name);
    p->set_title(d.title);
    p->set_type(d.type);
    p->set_unit(d.unit);
    p->set_min(d.min);
    p->set_max(d.max);
    p->set_has_default_value(d.default_value.has_value());
    p->set_default_value(d.default_value.value_or(0));
    p->set_writable(d.writable);
    p->set_has_stored_value(d.has_stored_value);
    p->set_description(d.description);
  }
  return out;
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::Store(
    const std::string& action, storage::ParameterSet set, bool create, const std::string& etag,
    const std::string& comment, const CallContext& c) {
  set.author = c.principal;
  absl::StatusOr<storage::ParameterSet> stored;
  std::optional<v1::ParameterSet> before;
  if (create) {
    stored = repo_.Create(set, comment);
  } else {
    if (auto old = repo_.Get(set.name); old.ok()) before = ToProto(*old);
    stored = repo_.Update(set, etag, comment);
  }
  absl::StatusOr<v1::ParameterSet> out =
      stored.ok() ? absl::StatusOr<v1::ParameterSet>(ToProto(*stored))
                  : EtagDetail(stored.status(), SetResource(kSetPrefix, set.name));
  std::string json;
  if (out.ok()) {
    json = BeforeAfterJson(before ? &*before : nullptr, &*out);
  } else {
    v1::ParameterSet attempted = ToProto(set);
    json = BeforeAfterJson(before ? &*before : nullptr, &attempted);
  }
  Audit(c, "", action, json, out.status());
  return out;
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::CreateParameterSet(
    const v1::CreateParameterSetRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    Audit(c, "", "CreateParameterSet", ToAuditJson(r), s);
    return s;
  };
  auto name = ParameterSetId("parameter_set.name", r.parameter_set().name());
  if (!name.ok()) return fail(name.status());
  auto cat = Catalogue("parameter_set.family", r.parameter_set().family());
  if (!cat.ok()) return fail(cat.status());
  storage::ParameterSet set;
  set.name = *name;
  set.family = r.parameter_set().family();
  set.model = r.parameter_set().model();
  set.description = r.parameter_set().description();
  set.target_stored = r.parameter_set().target_stored();
  set.values = FromProto(r.parameter_set().parameters());
  if (auto s = Resolve("parameter_set.parameters", **cat, set.values); !s.ok()) return fail(s);
  return Store("CreateParameterSet", std::move(set), true, "", r.comment(), c);
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::GetParameterSet(
    const v1::GetParameterSetRequest& r, const CallContext&) {
  auto name = ParameterSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto set = repo_.Get(*name);
  if (!set.ok()) return set.status();
  return ToProto(*set);
}

absl::StatusOr<v1::ListParameterSetsResponse> ParameterSetServiceCore::ListParameterSets(
    const v1::ListParameterSetsRequest& r, const CallContext&) {
  auto page = SetPageOf(r.page_size(), r.page_token(), storage::ParameterSetQuery::kMaxLimit);
  if (!page.ok()) return page.status();
  storage::ParameterSetQuery q;
  if (!r.family().empty()) q.family = r.family();
  q.after_name = page->after_name;
  q.limit = page->query_limit;
  auto sets = repo_.List(q);
  if (!sets.ok()) return sets.status();
  v1::ListParameterSetsResponse out;
  out.set_next_page_token(EmitPage(
      *sets, *page, [&](const auto& set) { *out.add_parameter_sets() = ToProto(set); },
      [](const auto& set) { return set.name; }));
  return out;
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::UpdateParameterSet(
    const v1::UpdateParameterSetRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    Audit(c, "", "UpdateParameterSet", ToAuditJson(r), s);
    return s;
  };
  auto name = ParameterSetId("parameter_set.name", r.parameter_set().name());
  if (!name.ok()) return fail(name.status());
  if (r.etag().empty()) return fail(FieldError("etag", "is required (updates are conditional)"));
  auto current = repo_.Get(*name);
  if (!current.ok()) return fail(current.status());
  if (!r.parameter_set().family().empty() && r.parameter_set().family() != current->family) {
    return fail(FieldError("parameter_set.family",
                           absl::StrCat("cannot change from '", current->family, "' to '",
                                        r.parameter_set().family(), "'")));
  }
  auto cat = Catalogue("parameter_set.family", current->family);
  if (!cat.ok()) return fail(cat.status());
  storage::ParameterSet set = *current;
  set.model = r.parameter_set().model();
  set.description = r.parameter_set().description();
  set.target_stored = r.parameter_set().target_stored();
  set.values = FromProto(r.parameter_set().parameters());
  if (auto s = Resolve("parameter_set.parameters", **cat, set.values); !s.ok()) return fail(s);
  return Store("UpdateParameterSet", std::move(set), false, r.etag(), r.comment(), c);
}

absl::StatusOr<v1::DeleteParameterSetResponse> ParameterSetServiceCore::DeleteParameterSet(
    const v1::DeleteParameterSetRequest& r, const CallContext& c) {
  std::string json = ToAuditJson(r);
  const absl::Status s = DeleteSet(
      repo_, ParameterSetId("name", r.name()), r.etag(), kSetPrefix,
      [](const storage::ParameterSet& set) { return ToProto(set); }, json);
  Audit(c, "", "DeleteParameterSet", json, s);
  if (!s.ok()) return s;
  return v1::DeleteParameterSetResponse();
}

absl::StatusOr<v1::ListParameterSetVersionsResponse>
ParameterSetServiceCore::ListParameterSetVersions(const v1::ListParameterSetVersionsRequest& r,
                                                  const CallContext&) {
  return ListSetVersions<v1::ListParameterSetVersionsResponse>(
      repo_, ParameterSetId("name", r.name()), kVersionToProto);
}

absl::StatusOr<v1::ParameterSetVersion> ParameterSetServiceCore::GetParameterSetVersion(
    const v1::GetParameterSetVersionRequest& r, const CallContext&) {
  return GetSetVersion(repo_, ParameterSetId("name", r.name()), r.version(), kVersionToProto);
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::CaptureParameterSet(
    const v1::CaptureParameterSetRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    Audit(c, r.drive(), "CaptureParameterSet", ToAuditJson(r), s);
    return s;
  };
  auto name = ParameterSetId("name", r.name());
  if (!name.ok()) return fail(name.status());
  auto drive = FindDrive("drive", r.drive());
  if (!drive.ok()) return fail(drive.status());
  const std::string family = (*drive)->config().family;
  auto cat = Catalogue("drive", family);
  if (!cat.ok()) return fail(cat.status());
  auto existing = repo_.Get(*name);
  const bool create = absl::IsNotFound(existing.status());
  if (!create && !existing.ok()) return fail(existing.status());
  storage::ParameterSet set;
  if (create) {
    set.name = *name;
    set.family = family;
    set.description = r.description();
  } else {
    if (existing->family != family) {
      return fail(FieldError("drive", absl::StrCat("is a ", family, " drive; set '", *name,
                                                   "' is for ", existing->family)));
    }
    if (r.etag().empty()) {
      return fail(FieldError(
          "etag", absl::StrCat("is required: set '", *name, "' exists (capture adds a version)")));
    }
    set = *existing;
  }
  std::vector<storage::ParameterValue> wanted;
  if (r.parameters().empty()) {
    if (create) return fail(FieldError("parameters", "is required for a new set"));
    wanted = set.values;
  } else {
    for (const auto& p : r.parameters()) wanted.push_back(storage::ParameterValue{p, 0, 0});
  }
  // Resolve names only (values are read next); the read values are validated by Store's caller
  // path through the applier's Diff, which reads every parameter of the set from the drive.
  std::set<uint32_t> seen;
  for (size_t i = 0; i < wanted.size(); ++i) {
    auto def = (*cat)->Find(wanted[i].parameter);
    if (!def.ok()) {
      return fail(
          FieldError(absl::StrCat("parameters[", i, "]"), std::string(def.status().message())));
    }
    if (!seen.insert(def->id).second) {
      return fail(FieldError(absl::StrCat("parameters[", i, "]"),
                             absl::StrCat(def->name, " is listed twice")));
    }
    wanted[i].parameter = def->name;
    wanted[i].id = def->id;
  }
  set.values = wanted;
  auto read = applier_.Diff(set, **drive);
  if (!read.ok()) return fail(read.status());
  for (size_t i = 0; i < set.values.size() && i < read->size(); ++i) {
    set.values[i].value = (*read)[i].current;
  }
  return Store("CaptureParameterSet", std::move(set), create, r.etag(), r.comment(), c);
}

absl::StatusOr<v1::DiffParameterSetResponse> ParameterSetServiceCore::DiffParameterSet(
    const v1::DiffParameterSetRequest& r, const CallContext&) {
  auto name = ParameterSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto a = SetAt(*name, r.version());
  if (!a.ok()) return a.status();
  v1::DiffParameterSetResponse out;
  if (r.other_case() == v1::DiffParameterSetRequest::kDrive) {
    auto drive = FindDrive("drive", r.drive());
    if (!drive.ok()) return drive.status();
    auto changes = applier_.Diff(*a, **drive);
    if (!changes.ok()) return changes.status();
    for (const auto& ch : *changes) {
      auto* d = out.add_parameters();
      d->set_parameter(ch.parameter);
      d->set_id(ch.id);
      d->set_a(ch.target);
      d->set_in_a(true);
      d->set_b(ch.current);
      d->set_in_b(true);
      d->set_differs(ch.differs);
      if (ch.differs) out.set_differing(out.differing() + 1);
    }
    return out;
  }
  std::string other = *name;
  if (r.other_case() == v1::DiffParameterSetRequest::kOtherSet) {
    auto o = ParameterSetId("other_set", r.other_set());
    if (!o.ok()) return o.status();
    other = *o;
  } else if (r.other_version() == 0) {
    return FieldError("other", "one of drive, other_set or other_version is required");
  }
  auto b = SetAt(other, r.other_version(), "other_version");
  if (!b.ok()) return b.status();
  // Union in a's order, then b's extra parameters.
  std::vector<uint32_t> order;
  std::map<uint32_t, std::pair<const storage::ParameterValue*, const storage::ParameterValue*>> m;
  for (const auto& v : a->values) {
    if (m.emplace(v.id, std::make_pair(&v, nullptr)).second) order.push_back(v.id);
  }
  for (const auto& v : b->values) {
    auto [it, added] = m.emplace(v.id, std::make_pair(nullptr, &v));
    if (added) {
      order.push_back(v.id);
    } else {
      it->second.second = &v;
    }
  }
  for (uint32_t id : order) {
    const auto [va, vb] = m[id];
    auto* d = out.add_parameters();
    d->set_parameter(va != nullptr ? va->parameter : vb->parameter);
    d->set_id(id);
    d->set_in_a(va != nullptr);
    d->set_in_b(vb != nullptr);
    if (va != nullptr) d->set_a(va->value);
    if (vb != nullptr) d->set_b(vb->value);
    d->set_differs(va == nullptr || vb == nullptr || va->value != vb->value);
    if (d->differs()) out.set_differing(out.differing() + 1);
  }
  return out;
}

absl::StatusOr<v1::Operation> ParameterSetServiceCore::ApplyParameterSet(
    const v1::ApplyParameterSetRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    Audit(c, "", "ApplyParameterSet", ToAuditJson(r), s);
    return s;
  };
  auto name = ParameterSetId("name", r.name());
  if (!name.ok()) return fail(name.status());
  if (r.drives().empty()) return fail(FieldError("drives", "is required (one or more drives)"));
  auto set = SetAt(*name, r.version());
  if (!set.ok()) return fail(set.status());
  ApplyRequest req;
  std::string drive_names;
  for (int i = 0; i < r.drives_size(); ++i) {
    auto d = FindDrive(absl::StrCat("drives[", i, "]"), r.drives(i));
    if (!d.ok()) return fail(d.status());
    if ((*d)->config().family != set->family) {
      return fail(FieldError(absl::StrCat("drives[", i, "]"),
                             absl::StrCat("is a ", (*d)->config().family, " drive; set '", *name,
                                          "' is for ", set->family)));
    }
    // A dry run only reads; writes need the lease (decision 019).
    if (!r.dry_run()) {
      if (auto s = CheckLease(leases_, (*d)->config().name, c); !s.ok()) return fail(s);
    }
    req.drives.push_back(*d);
    absl::StrAppend(&drive_names, drive_names.empty() ? "" : ",", (*d)->config().name);
  }
  req.set = *set;
  req.dry_run = r.dry_run();
  req.principal = c.principal;
  // The final state (with pre-images and what was written) is audited when the operation ends.
  storage::AuditLog* audit = audit_;
  auto op =
      applier_.Start(std::move(req), [audit, c, drive_names](const storage::ApplyOperation& done) {
        const v1::Operation p = ToProto(done);
        absl::Status result = done.state == "SUCCEEDED"
                                  ? absl::OkStatus()
                                  : absl::AbortedError(absl::StrCat(p.name(), " ", done.state));
        WriteAudit(audit, c, drive_names, "ApplyParameterSet.done", ToAuditJson(p), result);
      });
  if (!op.ok()) return fail(op.status());
  v1::Operation out = ToProto(*op);
  Audit(c, drive_names, "ApplyParameterSet",
        absl::StrCat("{\"request\":", ToAuditJson(r), ",\"operation\":\"", out.name(), "\"}"),
        absl::OkStatus());
  return out;
}

absl::StatusOr<v1::Operation> ParameterSetServiceCore::GetOperation(
    const v1::GetOperationRequest& r, const CallContext&) {
  auto id = OperationId("name", r.name());
  if (!id.ok()) return id.status();
  auto op = repo_.GetOperation(*id);
  if (!op.ok()) return op.status();
  return ToProto(*op);
}

absl::StatusOr<v1::Operation> ParameterSetServiceCore::RestoreOperation(
    const v1::RestoreOperationRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    Audit(c, "", "RestoreOperation", ToAuditJson(r), s);
    return s;
  };
  auto id = OperationId("name", r.name());
  if (!id.ok()) return fail(id.status());
  auto op = repo_.GetOperation(*id);
  if (!op.ok()) return fail(op.status());
  if (op->state == "RUNNING") {
    return fail(absl::FailedPreconditionError(
        absl::StrCat("name: operation ", *id, " is still RUNNING; restore it once it ended")));
  }
  if (op->dry_run) {
    return fail(absl::FailedPreconditionError(
        absl::StrCat("name: operation ", *id, " was a dry run and wrote nothing")));
  }
  // Which drives: the ones asked for (each must have values to restore), else every drive
  // that has some.
  std::vector<const storage::ApplyDriveResult*> chosen;
  for (int i = 0; i < r.drives_size(); ++i) {
    const std::string field = absl::StrCat("drives[", i, "]");
    absl::string_view want = r.drives(i);
    if (absl::StartsWith(want, "drives/")) want.remove_prefix(7);
    const storage::ApplyDriveResult* found = nullptr;
    for (const auto& d : op->drives) {
      if (d.drive == want) found = &d;
    }
    if (found == nullptr) {
      return fail(FieldError(field, absl::StrCat("'", r.drives(i), "' is not a drive of ", *id)));
    }
    if (!HasValuesToRestore(*found)) {
      return fail(FieldError(field, absl::StrCat("drive '", found->drive, "' is ", found->state,
                                                 " in ", *id, ": nothing to restore")));
    }
    chosen.push_back(found);
  }
  if (r.drives().empty()) {
    for (const auto& d : op->drives) {
      if (HasValuesToRestore(d)) chosen.push_back(&d);
    }
  }
  if (chosen.empty()) {
    return fail(absl::FailedPreconditionError(absl::StrCat(
        "name: operation ", *id, " (", op->state, ") left no drive with values to restore")));
  }
  ApplyRequest req;
  std::string drive_names;
  for (size_t i = 0; i < chosen.size(); ++i) {
    auto d = FindDrive(absl::StrCat("drives[", i, "]"), chosen[i]->drive);
    if (!d.ok()) return fail(d.status());
    if (auto s = CheckLease(leases_, (*d)->config().name, c); !s.ok()) return fail(s);
    req.drives.push_back(*d);
    req.per_drive_values.push_back(chosen[i]->pre_image);
    absl::StrAppend(&drive_names, drive_names.empty() ? "" : ",", (*d)->config().name);
  }
  // The family is the drives' (the set may be gone; a drive's family cannot change while the
  // gateway runs, and the applier refuses a mismatch between them).
  req.set.name = op->set_name;
  req.set.version = op->set_version;
  req.set.family = req.drives.front()->config().family;
  req.set.target_stored = op->target_stored;
  req.principal = c.principal;
  req.restores = *id;
  storage::AuditLog* audit = audit_;
  auto started =
      applier_.Start(std::move(req), [audit, c, drive_names](const storage::ApplyOperation& done) {
        const v1::Operation p = ToProto(done);
        absl::Status result = done.state == "SUCCEEDED"
                                  ? absl::OkStatus()
                                  : absl::AbortedError(absl::StrCat(p.name(), " ", done.state));
        WriteAudit(audit, c, drive_names, "RestoreOperation.done", ToAuditJson(p), result);
      });
  if (!started.ok()) return fail(started.status());
  v1::Operation out = ToProto(*started);
  Audit(c, drive_names, "RestoreOperation",
        absl::StrCat("{\"request\":", ToAuditJson(r), ",\"operation\":\"", out.name(), "\"}"),
        absl::OkStatus());
  return out;
}

absl::StatusOr<int> ParameterSetServiceCore::MarkInterrupted() {
  auto ops = repo_.InterruptRunning(
      "the gateway stopped during the apply; some values may be written: restore the pre-image");
  if (!ops.ok()) return ops.status();
  // One entry per operation, as the system (no caller): what was interrupted, with the
  // pre-images, so the audit trail alone says what to restore.
  CallContext system;
  system.principal = "drivegw";  // as the shutdown stop's entries (server/ops/shutdown.cpp)
  system.transport = "startup";
  for (const auto& op : *ops) {
    std::string drive_names;
    for (const auto& d : op.drives) {
      absl::StrAppend(&drive_names, drive_names.empty() ? "" : ",", d.drive);
    }
    const v1::Operation p = ToProto(op);
    WriteAudit(audit_, system, drive_names, "ApplyParameterSet.interrupted", ToAuditJson(p),
               absl::AbortedError(absl::StrCat(p.name(), " INTERRUPTED")));
  }
  return static_cast<int>(ops->size());
}

absl::StatusOr<v1::ListOperationsResponse> ParameterSetServiceCore::ListOperations(
    const v1::ListOperationsRequest& r, const CallContext&) {
  if (r.page_size() < 0 || r.page_size() > 1000) {
    return FieldError("page_size", absl::StrCat(r.page_size(), " is outside 0..1000"));
  }
  auto ops = repo_.ListOperations(r.page_size() == 0 ? 100 : r.page_size());
  if (!ops.ok()) return ops.status();
  v1::ListOperationsResponse out;
  for (const auto& op : *ops) *out.add_operations() = ToProto(op);
  return out;
}

absl::StatusOr<v1::ParameterSet> ParameterSetServiceCore::ImportParameterSet(
    const v1::ImportParameterSetRequest& r, const CallContext& c) {
  auto fail = [&](absl::Status s) {
    v1::ImportParameterSetRequest logged = r;
    if (logged.content().size() > 4096) logged.mutable_content()->resize(4096);
    Audit(c, "", "ImportParameterSet", ToAuditJson(logged), s);
    return s;
  };
  absl::StatusOr<storage::ParameterSet> parsed;
  switch (r.format()) {
    case v1::PARAMETER_SET_FORMAT_JSON:
      parsed = ParseParameterSetJson(r.content());
      break;
    case v1::PARAMETER_SET_FORMAT_CSV:
      parsed = ParseParameterSetCsv(r.content());
      break;
    default:
      return fail(FieldError("format", "is required (PARAMETER_SET_FORMAT_JSON or _CSV)"));
  }
  if (!parsed.ok()) return fail(FieldError("content", std::string(parsed.status().message())));
  storage::ParameterSet set = *std::move(parsed);
  if (!r.name().empty()) set.name = r.name();
  if (!r.family().empty()) set.family = r.family();
  auto name = ParameterSetId("name", set.name);
  if (!name.ok()) return fail(name.status());
  set.name = *name;
  auto cat = Catalogue("family", set.family);
  if (!cat.ok()) return fail(cat.status());
  if (auto s = Resolve("content.parameters", **cat, set.values); !s.ok()) return fail(s);
  auto existing = repo_.Get(set.name);
  const bool create = absl::IsNotFound(existing.status());
  if (!create && !existing.ok()) return fail(existing.status());
  if (!create) {
    if (existing->family != set.family) {
      return fail(
          FieldError("family", absl::StrCat("set '", set.name, "' is for ", existing->family,
                                            ", the file for ", set.family)));
    }
    if (r.etag().empty()) {
      return fail(FieldError("etag", absl::StrCat("is required: set '", set.name,
                                                  "' exists (import adds a version)")));
    }
    if (r.format() == v1::PARAMETER_SET_FORMAT_CSV) {
      // A CSV file carries values only: the set's other fields stay as they are.
      set.model = existing->model;
      set.description = existing->description;
      set.target_stored = existing->target_stored;
    }
  }
  return Store("ImportParameterSet", std::move(set), create, r.etag(), r.comment(), c);
}

absl::StatusOr<v1::ExportParameterSetResponse> ParameterSetServiceCore::ExportParameterSet(
    const v1::ExportParameterSetRequest& r, const CallContext&) {
  auto name = ParameterSetId("name", r.name());
  if (!name.ok()) return name.status();
  auto set = SetAt(*name, r.version());
  if (!set.ok()) return set.status();
  v1::ExportParameterSetResponse out;
  switch (r.format()) {
    case v1::PARAMETER_SET_FORMAT_UNSPECIFIED:  // JSON by default: it carries the whole set
    case v1::PARAMETER_SET_FORMAT_JSON:
      out.set_content(ParameterSetToJson(*set));
      out.set_content_type("application/json");
      break;
    case v1::PARAMETER_SET_FORMAT_CSV:
      out.set_content(ParameterSetToCsv(*set));
      out.set_content_type("text/csv");
      break;
    default:
      return FieldError("format", absl::StrCat(static_cast<int>(r.format()), " is not a format"));
  }
  return out;
}

}  // namespace drivegw::server
