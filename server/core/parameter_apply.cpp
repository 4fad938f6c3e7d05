// ParameterApplier: validate → pre-image → write → read back → restore, one drive after the
// other (issue 6, docs/decisions/010-parameter-apply.md).
#include "server/core/parameter_apply.h"

#include <algorithm>
#include <atomic>
#include <functional>
#include <mutex>
#include <set>
#include <thread>
#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw::server {
namespace {

using storage::ApplyDriveResult;
using storage::ApplyOperation;
using storage::ParameterValue;

// One value of the set with the catalogue definition it resolved to.
struct Resolved {
  ParameterValue value;  // parameter = canonical catalogue name, id = definition id
  ParameterDefinition definition;
};

// Operation and drive states (storage/parameter_set_repo.h).
constexpr char kRunning[] = "RUNNING";
constexpr char kSucceeded[] = "SUCCEEDED";
constexpr char kFailed[] = "FAILED";
constexpr char kFailedRollback[] = "FAILED_ROLLBACK";
constexpr char kPending[] = "PENDING";
constexpr char kApplying[] = "APPLYING";
constexpr char kApplied[] = "APPLIED";
constexpr char kRolledBack[] = "ROLLED_BACK";
constexpr char kRollbackFailed[] = "ROLLBACK_FAILED";
constexpr char kUnchanged[] = "UNCHANGED";

std::string DriveName(const Drive& drive) { return drive.config().name; }

// Writes `value` and reads it back; the error text is what the operation reports.
absl::Status WriteVerified(Drive& drive, const ParameterRef& ref, int64_t value) {
  if (absl::Status s = drive.WriteParameter(ref, value); !s.ok()) return s;
  absl::StatusOr<int64_t> back = drive.ReadParameter(ref);
  if (!back.ok()) return back.status();
  if (*back != value) {
    return absl::DataLossError(
        absl::StrCat("read back ", std::to_string(*back), ", wrote ", std::to_string(value)));
  }
  return absl::OkStatus();
}

std::string Message(const absl::Status& s) { return std::string(s.message()); }

}  // namespace

struct ParameterApplier::Impl {
  storage::ParameterSetRepo& repo;
  const CatalogueList& catalogues;

  std::mutex mu;  // guards workers and serialises repo writes of concurrent operations
  struct Worker {
    std::thread thread;
    std::shared_ptr<std::atomic<bool>> done;
  };
  std::vector<Worker> workers;

  Impl(storage::ParameterSetRepo& r, const CatalogueList& c) : repo(r), catalogues(c) {}

  absl::StatusOr<const ParameterCatalogue*> Find(const std::string& family) const {
    for (const auto& c : catalogues) {
      if (c && c->family() == family) return c.get();
    }
    return absl::NotFoundError(absl::StrCat("no parameter catalogue for family '", family, "'"));
  }

  // Step 1 for the whole request: every drive of the family, every value in the catalogue and
  // within its limits; nothing is written when any check fails. One resolved list per drive
  // (the same list for each, unless the request carries per-drive values: a restore).
  absl::StatusOr<std::vector<std::vector<Resolved>>> Validate(const ApplyRequest& request) const {
    const storage::ParameterSet& set = request.set;
    absl::StatusOr<const ParameterCatalogue*> catalogue = Find(set.family);
    if (!catalogue.ok()) return catalogue.status();
    if (request.drives.empty()) {
      return absl::InvalidArgumentError(
          absl::StrCat("drives: apply of set '", set.name, "' names no drive"));
    }
    if (!request.per_drive_values.empty() &&
        request.per_drive_values.size() != request.drives.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("per_drive_values: ", request.per_drive_values.size(), " lists for ",
                       request.drives.size(), " drives"));
    }
    std::set<std::string> names;
    for (const Drive* d : request.drives) {
      if (d == nullptr) return absl::InvalidArgumentError("drives: null drive");
      if (d->config().family != set.family) {
        return absl::InvalidArgumentError(absl::StrCat("drive '", DriveName(*d), "' is of family '",
                                                       d->config().family, "', set '", set.name,
                                                       "' is for '", set.family, "'"));
      }
      if (!names.insert(DriveName(*d)).second) {
        return absl::InvalidArgumentError(
            absl::StrCat("drives: drive '", DriveName(*d), "' listed twice"));
      }
    }
    std::vector<std::vector<Resolved>> out;
    if (request.per_drive_values.empty()) {
      // The catalogue is the family's, so the drive named in a refusal is the first of the
      // request: every drive would refuse the same value.
      absl::StatusOr<std::vector<Resolved>> values =
          Resolve(set, **catalogue, set.values, DriveName(*request.drives.front()));
      if (!values.ok()) return values.status();
      out.assign(request.drives.size(), *values);
      return out;
    }
    for (size_t i = 0; i < request.drives.size(); ++i) {
      absl::StatusOr<std::vector<Resolved>> values =
          Resolve(set, **catalogue, request.per_drive_values[i], DriveName(*request.drives[i]));
      if (!values.ok()) return values.status();
      out.push_back(*std::move(values));
    }
    return out;
  }

  static absl::StatusOr<std::vector<Resolved>> Resolve(const storage::ParameterSet& set,
                                                       const ParameterCatalogue& catalogue,
                                                       const std::vector<ParameterValue>& values,
                                                       const std::string& drive) {
    std::vector<Resolved> out;
    out.reserve(values.size());
    for (const ParameterValue& v : values) {
      const std::string key = v.parameter.empty() ? std::to_string(v.id) : v.parameter;
      absl::StatusOr<ParameterDefinition> def = catalogue.Find(key);
      if (!def.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("set '", set.name, "', drive '", drive, "': ", Message(def.status())));
      }
      if (v.id != 0 && v.id != def->id) {
        return absl::InvalidArgumentError(
            absl::StrCat("set '", set.name, "': parameter ", key, " has id ", std::to_string(v.id),
                         " but the ", set.family, " catalogue says ", std::to_string(def->id)));
      }
      if (set.target_stored && !def->has_stored_value) {
        return absl::InvalidArgumentError(
            absl::StrCat("set '", set.name, "', drive '", drive, "': ", def->name,
                         " has no stored (ROM) value; target_stored needs one"));
      }
      if (absl::Status s = catalogue.Validate(*def, v.value); !s.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("set '", set.name, "', drive '", drive, "': ", Message(s)));
      }
      out.push_back({ParameterValue{def->name, def->id, v.value}, *def});
    }
    return out;
  }

  ApplyOperation NewOperation(const ApplyRequest& request) const {
    ApplyOperation op;
    op.set_name = request.set.name;
    op.set_version = request.set.version;
    op.dry_run = request.dry_run;
    op.state = kRunning;
    op.principal = request.principal;
    op.target_stored = request.set.target_stored;
    op.restores = request.restores;
    for (const Drive* d : request.drives) {
      ApplyDriveResult r;
      r.drive = DriveName(*d);
      r.state = kPending;
      op.drives.push_back(std::move(r));
    }
    return op;
  }

  // A failed progress store must not stop the restore logic of a running apply (the final state
  // is retried with the next update); only the store before the first write is checked.
  absl::Status Store(const ApplyOperation& op) {
    std::lock_guard lock(mu);
    return repo.UpdateOperation(op);
  }

  // Steps 2-5 on one drive. Returns false when the drive failed (rolled back or not).
  // `before_first_write` stores the operation with this drive APPLYING and its pre-image: from
  // then on a crash leaves a record of what to restore (decision 1441).
  static bool ApplyToDrive(Drive& drive, const std::vector<Resolved>& values, bool rom,
                           bool dry_run, ApplyDriveResult& result,
                           const std::function<absl::Status()>& before_first_write) {
    // (2) Pre-image: every parameter once, before anything is written.
    std::vector<std::pair<uint32_t, int64_t>> before;  // id -> value, set order
    auto pre = [&](uint32_t id) -> const int64_t* {
      for (const auto& [i, v] : before) {
        if (i == id) return &v;
      }
      return nullptr;
    };
    for (const Resolved& r : values) {
      if (pre(r.value.id) != nullptr) continue;
      absl::StatusOr<int64_t> v = drive.ReadParameter({r.value.id, rom});
      if (!v.ok()) {
        // Nothing was written yet: the drive is as it was.
        result.state = kRolledBack;
        result.failed_parameter = r.value.parameter;
        result.error = absl::StrCat("reading the pre-image: ", Message(v.status()));
        return false;
      }
      before.emplace_back(r.value.id, *v);
      result.pre_image.push_back({r.value.parameter, r.value.id, *v});
    }

    // (3) Dry run: `written` lists what would be written; nothing goes to the drive.
    if (dry_run) {
      for (const Resolved& r : values) {
        if (*pre(r.value.id) != r.value.value) result.written.push_back(r.value);
      }
      result.state = kUnchanged;
      return true;
    }

    // (4) Write what differs, read back, compare. The pre-image is durable first.
    // Without a stored pre-image nothing is written: a crash would leave no way back.
    result.state = kApplying;
    if (absl::Status s = before_first_write(); !s.ok()) {
      result.state = kRolledBack;
      result.error = absl::StrCat("storing the pre-image: ", Message(s));
      return false;
    }
    std::vector<const Resolved*> touched;  // changed on the drive, in write order
    std::string failure;
    const Resolved* failed = nullptr;
    for (const Resolved& r : values) {
      if (*pre(r.value.id) == r.value.value) continue;  // equal: no waste
      const ParameterRef ref{r.value.id, rom};
      absl::Status s = WriteVerified(drive, ref, r.value.value);
      if (s.ok()) {
        touched.push_back(&r);
        result.written.push_back(r.value);
        continue;
      }
      failed = &r;
      failure = Message(s);
      // A refused write leaves the old value; a mismatch or an unanswered write may not: restore
      // this one too unless the drive still reports its pre-image.
      absl::StatusOr<int64_t> now = drive.ReadParameter(ref);
      if (!now.ok() || *now != *pre(r.value.id)) touched.push_back(&r);
      break;
    }
    if (failed == nullptr) {
      result.state = result.written.empty() ? kUnchanged : kApplied;
      return true;
    }

    // Restore the pre-image, newest change first (undo order keeps cross-field rules that held
    // before the apply satisfied at every step), each parameter once, verified by reading back.
    result.failed_parameter = failed->value.parameter;
    result.error = failure;
    std::vector<std::string> not_restored;
    std::set<uint32_t> restored;
    for (auto it = touched.rbegin(); it != touched.rend(); ++it) {
      const Resolved& r = **it;
      if (!restored.insert(r.value.id).second) continue;
      absl::Status s = WriteVerified(drive, {r.value.id, rom}, *pre(r.value.id));
      if (!s.ok()) not_restored.push_back(absl::StrCat(r.value.parameter, " (", Message(s), ")"));
    }
    // `written` keeps only what is still on the drive: nothing when fully restored.
    if (not_restored.empty()) {
      result.state = kRolledBack;
      result.written.clear();
    } else {
      result.state = kRollbackFailed;
      std::string list;
      for (const auto& n : not_restored) list += (list.empty() ? "" : ", ") + n;
      result.error = absl::StrCat(failure, "; not restored: ", list);
    }
    return false;
  }

  ApplyOperation Execute(const ApplyRequest& request,
                         const std::vector<std::vector<Resolved>>& values, ApplyOperation op) {
    const bool rom = request.set.target_stored;
    op.state = kSucceeded;
    auto store_running = [&] {
      ApplyOperation progress = op;
      progress.state = kRunning;
      return Store(progress);
    };
    for (size_t i = 0; i < request.drives.size(); ++i) {
      ApplyDriveResult& result = op.drives[i];
      const bool ok =
          ApplyToDrive(*request.drives[i], values[i], rom, request.dry_run, result, store_running);
      if (!ok) {
        // Stop at the first failing drive: the next drives keep their values (PENDING).
        op.state = result.state == kRollbackFailed ? kFailedRollback : kFailed;
        break;
      }
      if (i + 1 < request.drives.size()) (void)store_running();
    }
    (void)Store(op);
    if (absl::StatusOr<ApplyOperation> stored = repo.GetOperation(op.id); stored.ok()) {
      return *stored;
    }
    return op;
  }

  absl::StatusOr<std::pair<std::vector<std::vector<Resolved>>, ApplyOperation>> Prepare(
      const ApplyRequest& request) {
    absl::StatusOr<std::vector<std::vector<Resolved>>> values = Validate(request);
    if (!values.ok()) return values.status();
    absl::StatusOr<ApplyOperation> op;
    {
      std::lock_guard lock(mu);
      op = repo.CreateOperation(NewOperation(request));
    }
    if (!op.ok()) return op.status();
    return std::make_pair(*std::move(values), *std::move(op));
  }

  void ReapFinished() {  // holds mu
    auto done = [](Worker& w) {
      if (!w.done->load()) return false;
      w.thread.join();
      return true;
    };
    workers.erase(std::remove_if(workers.begin(), workers.end(), done), workers.end());
  }
};

ParameterApplier::ParameterApplier(storage::ParameterSetRepo& repo, const CatalogueList& catalogues)
    : impl_(std::make_unique<Impl>(repo, catalogues)) {}

ParameterApplier::~ParameterApplier() {
  std::vector<Impl::Worker> workers;
  {
    std::lock_guard lock(impl_->mu);
    workers.swap(impl_->workers);
  }
  for (auto& w : workers) w.thread.join();
}

absl::StatusOr<storage::ApplyOperation> ParameterApplier::Start(
    ApplyRequest request, std::function<void(const storage::ApplyOperation&)> on_done) {
  auto prepared = impl_->Prepare(request);
  if (!prepared.ok()) return prepared.status();
  ApplyOperation started = prepared->second;
  auto done = std::make_shared<std::atomic<bool>>(false);
  std::lock_guard lock(impl_->mu);
  impl_->ReapFinished();
  impl_->workers.push_back(
      {std::thread([impl = impl_.get(), request = std::move(request),
                    prepared = *std::move(prepared), on_done = std::move(on_done), done] {
         ApplyOperation final_op = impl->Execute(request, prepared.first, prepared.second);
         if (on_done) on_done(final_op);
         done->store(true);
       }),
       done});
  return started;
}

absl::StatusOr<storage::ApplyOperation> ParameterApplier::Run(ApplyRequest request) {
  auto prepared = impl_->Prepare(request);
  if (!prepared.ok()) return prepared.status();
  return impl_->Execute(request, prepared->first, prepared->second);
}

absl::StatusOr<std::vector<ParameterChange>> ParameterApplier::Diff(
    const storage::ParameterSet& set, Drive& drive) {
  std::vector<ParameterChange> out;
  out.reserve(set.values.size());
  for (const ParameterValue& v : set.values) {
    absl::StatusOr<int64_t> current = drive.ReadParameter({v.id, set.target_stored});
    if (!current.ok()) {
      return absl::Status(current.status().code(),
                          absl::StrCat("drive '", DriveName(drive), "': ", v.parameter, ": ",
                                       Message(current.status())));
    }
    out.push_back({v.parameter, v.id, *current, v.value, *current != v.value});
  }
  return out;
}

absl::StatusOr<const ParameterCatalogue*> ParameterApplier::Catalogue(
    const std::string& family) const {
  return impl_->Find(family);
}

}  // namespace drivegw::server
