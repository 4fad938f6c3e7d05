// DriveEventRecorder: snapshot comparison per drive, rate-bounded audit entries.
#include "server/core/drive_event_recorder.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "nlohmann/json.hpp"
#include "server/core/audit.h"
#include "server/core/call_context.h"

namespace drivegw::server {
namespace {

// A wait slice: the longest Stop() waits for a watcher.
constexpr auto kSlice = std::chrono::milliseconds(200);

std::string StateJson(const DriveStatus& s) {
  return nlohmann::json{{"state", ToString(s.state)}}.dump();
}

bool HasFault(const DriveStatus& s) { return s.fault.code != 0 || s.state == DriveState::kFault; }

}  // namespace

std::vector<DriveEvent> DriveEventsBetween(const DriveStatus& before, const DriveStatus& after) {
  std::vector<DriveEvent> out;
  const bool was_offline = before.state == DriveState::kOffline;
  const bool is_offline = after.state == DriveState::kOffline;
  if (was_offline != is_offline) {
    out.push_back({is_offline ? "drive.offline" : "drive.online",
                   nlohmann::json{{"native_state", after.native.text}}.dump(),
                   is_offline ? "the drive stopped answering" : "the drive answers",
                   StateJson(before), StateJson(after)});
  }
  // Health (decision 1431): every change of UP/DEMOTED/DOWN. A drive without a snapshot health
  // yet counts as DEMOTED ("no reply yet", where every HealthModel starts), so activation itself
  // is no event but a drive first seen UP or DOWN is.
  const HealthState health_before = before.health ? before.health->state : HealthState::kDemoted;
  if (after.health && after.health->state != health_before) {
    const HealthInfo& h = *after.health;
    out.push_back({"drive.health",
                   nlohmann::json{{"state", ToString(h.state)},
                                  {"since", FormatRfc3339Utc(h.since)},
                                  {"consecutive_failures", h.consecutive_failures},
                                  {"reason", h.reason}}
                       .dump(),
                   h.reason.empty() ? absl::StrCat("health ", ToString(h.state))
                                    : absl::StrCat("health ", ToString(h.state), ": ", h.reason),
                   nlohmann::json{{"health", ToString(health_before)}}.dump(),
                   nlohmann::json{{"health", ToString(h.state)}}.dump()});
  }
  const bool fault_changed = HasFault(before) != HasFault(after) ||
                             before.fault.code != after.fault.code ||
                             before.fault.text != after.fault.text;
  if (HasFault(after) && fault_changed) {
    // The drive's own code and text (e.g. a LinMot error code, a CiA 402 error code).
    out.push_back({"drive.fault",
                   nlohmann::json{{"code", after.fault.code},
                                  {"code_hex", absl::StrCat("0x", absl::Hex(after.fault.code))},
                                  {"text", after.fault.text},
                                  {"fatal", after.fault.fatal},
                                  {"native_state", after.native.text}}
                       .dump(),
                   after.fault.text.empty() ? std::string("drive fault") : after.fault.text,
                   StateJson(before), StateJson(after)});
  } else if (HasFault(before) && !HasFault(after)) {
    out.push_back({"drive.fault_cleared",
                   nlohmann::json{{"code", before.fault.code}, {"text", before.fault.text}}.dump(),
                   "fault cleared", StateJson(before), StateJson(after)});
  }
  if (before.warnings != after.warnings) {
    if (after.warnings.empty()) {
      out.push_back({"drive.warning_cleared", nlohmann::json{{"warnings", before.warnings}}.dump(),
                     "warnings cleared", "", ""});
    } else {
      std::vector<std::string> added;
      for (const auto& w : after.warnings) {
        if (std::find(before.warnings.begin(), before.warnings.end(), w) == before.warnings.end()) {
          added.push_back(w);
        }
      }
      out.push_back({"drive.warning",
                     nlohmann::json{{"warnings", after.warnings},
                                    {"added", added},
                                    {"warn_word", after.native.warn_word}}
                         .dump(),
                     absl::StrJoin(after.warnings, ", "), "", ""});
    }
  }
  if (!before.homed && after.homed) {
    out.push_back({"drive.homed", nlohmann::json{{"position_mm", after.position_mm}}.dump(),
                   "homing done", nlohmann::json{{"homed", false}}.dump(),
                   nlohmann::json{{"homed", true}}.dump()});
  }
  return out;
}

int64_t EventBudget::Roll(TimePoint now) {
  if (now - window_start_ < window_) return 0;
  const int64_t suppressed = suppressed_;
  window_start_ = now;
  taken_ = 0;
  suppressed_ = 0;
  return suppressed;
}

bool EventBudget::Take() {
  if (taken_ >= max_) {
    ++suppressed_;
    return false;
  }
  ++taken_;
  return true;
}

DriveEventRecorder::DriveEventRecorder(std::vector<std::shared_ptr<Drive>> drives,
                                       storage::AuditLog* audit)
    : audit_(audit) {
  for (auto& d : drives) {
    threads_.emplace_back([this, d = std::move(d)] { Watch(d); });
  }
}

DriveEventRecorder::~DriveEventRecorder() { Stop(); }

void DriveEventRecorder::Stop() {
  {
    std::lock_guard lock(mu_);
    stop_.store(true);
  }
  stopped_.notify_all();
  for (auto& t : threads_) {
    if (t.joinable()) t.join();
  }
}

bool DriveEventRecorder::Sleep(std::chrono::milliseconds d) {
  std::unique_lock lock(mu_);
  return !stopped_.wait_for(lock, d, [&] { return stop_.load(); });
}

void DriveEventRecorder::Watch(const std::shared_ptr<Drive>& drive) {
  const std::string name = drive->config().name;
  CallContext who;
  who.principal = absl::StrCat("drive:", name);
  who.source_address = drive->endpoint();
  who.transport = "drive";
  DriveStatus last;  // a drive starts OFFLINE (DriveStatus's default)
  EventBudget budget(kMaxEventsPerWindow, kWindow, std::chrono::steady_clock::now());
  while (!stop_.load()) {
    // Woken only by snapshots with an event field changed (EventFieldsDiffer), not by
    // every position a moving axis publishes each cycle (issue 10).
    DriveStatus s =
        drive->WaitForEventStatus(last.sequence, std::chrono::steady_clock::now() + kSlice);
    if (stop_.load()) break;
    if (s.sequence == last.sequence) {
      // No news: a deactivated drive returns at once, so rest a slice instead of spinning.
      if (drive->lifecycle() == Lifecycle::kInactive && !Sleep(kSlice)) break;
      continue;
    }
    if (const int64_t suppressed = budget.Roll(std::chrono::steady_clock::now()); suppressed > 0) {
      WriteAudit(audit_, who,
                 AuditWrite{name, "drive.events_suppressed",
                            nlohmann::json{{"suppressed", suppressed},
                                           {"window_s", kWindow.count()},
                                           {"max_per_window", kMaxEventsPerWindow}}
                                .dump(),
                            absl::OkStatus(), "", "", ""});
    }
    for (DriveEvent& e : DriveEventsBetween(last, s)) {
      if (!budget.Take()) continue;
      // The recording worked: OK as result; the drive's code and text are in request/message.
      WriteAudit(audit_, who,
                 AuditWrite{name, e.action, e.request_json, absl::OkStatus(), e.before_json,
                            e.after_json, e.message});
    }
    last = std::move(s);
  }
}

}  // namespace drivegw::server
