// CanopenMaster SYNC producer: its own thread on absolute steady-clock deadlines (no drift),
// the counter of 1019h, jitter counters, the "SYNC sent" listeners (decision 1116) and the cycle
// boundary of synchronous RPDO pacing (decision 1118).
// Source: CiA 301 v4.2.0 §7.2.5 (SYNC), §7.5.2.6 (1006h communication cycle period),
// §7.5.2.22 (1019h synchronous counter overflow value).
#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/canopen/master.h"
#include "adapters/canopen/sync.h"
#include "adapters/core/log.h"

namespace drivegw::canopen {
namespace {

// Shortest period accepted: the user-space bus and a thread timer cannot hold less with any
// meaning, and CiA 402 drives rarely run below 1 ms (decision 1116).
constexpr Duration kMinSyncPeriod = std::chrono::milliseconds(1);

Duration Abs(Duration d) { return d < Duration::zero() ? -d : d; }

}  // namespace

absl::Status CanopenMaster::StartSync(Duration period, uint8_t counter_overflow) {
  if (period < kMinSyncPeriod) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen sync.period: ",
                     std::chrono::duration_cast<std::chrono::microseconds>(period).count(),
                     " us below 1000 us (decision 1116)"));
  }
  if (counter_overflow == 1 || counter_overflow > kSyncCounterMax) {
    return absl::InvalidArgumentError(
        absl::StrCat("canopen sync.counter_overflow: ", counter_overflow,
                     " is reserved (0 = no counter, or 2..240; CiA 301 1019h)"));
  }
  if (std::this_thread::get_id() == sync_thread_id_.load()) {
    return absl::FailedPreconditionError(
        "canopen StartSync: called from a SYNC listener (it would join its own thread)");
  }
  std::lock_guard control(sync_control_mu_);
  StopSync();
  {
    std::lock_guard lock(mu_);
    if (stopping_) {
      return absl::FailedPreconditionError(absl::StrCat("canopen master ", bus_name_, ": stopped"));
    }
    counters_.sync_last_period_error = Duration::zero();
    counters_.sync_max_period_error = Duration::zero();
  }
  {
    // From here SendRpdo paces synchronous RPDOs on this producer's cycles (decision 1118).
    std::lock_guard pacing(rpdo_mu_);
    sync_pacing_ = true;
  }
  std::lock_guard lock(sync_mu_);
  sync_stop_ = false;
  sync_thread_ =
      std::thread([this, period, counter_overflow] { RunSync(period, counter_overflow); });
  log::Info(
      "canopen_sync_started",
      log::Fields()
          .Add("bus", bus_name_)
          .Add("period_us", std::chrono::duration_cast<std::chrono::microseconds>(period).count())
          .Add("counter_overflow", static_cast<int>(counter_overflow)));
  return absl::OkStatus();
}

void CanopenMaster::StopSync() {
  if (std::this_thread::get_id() == sync_thread_id_.load()) {
    // From a listener: flag only; the thread ends after the listener returns and the next
    // StartSync / StopSync / Stop joins it.
    std::lock_guard lock(sync_mu_);
    sync_stop_ = true;
    return;
  }
  std::thread t;
  {
    std::lock_guard lock(sync_mu_);
    sync_stop_ = true;
    sync_cv_.notify_all();
    t = std::move(sync_thread_);
  }
  if (t.joinable()) {
    t.join();
    log::Info("canopen_sync_stopped", log::Fields().Add("bus", bus_name_));
  }
}

bool CanopenMaster::sync_running() const {
  std::lock_guard lock(sync_mu_);
  return sync_thread_.joinable() && !sync_stop_;
}

SyncListenerId CanopenMaster::AddSyncListener(SyncListener listener) {
  std::lock_guard lock(sync_mu_);
  const SyncListenerId id = next_sync_listener_++;
  sync_listeners_[id] = std::move(listener);
  return id;
}

void CanopenMaster::RemoveSyncListener(SyncListenerId id) {
  {
    std::lock_guard lock(sync_mu_);
    sync_listeners_.erase(id);
  }
  // Wait for a delivery in progress, unless this is that delivery.
  if (std::this_thread::get_id() != sync_thread_id_.load()) std::lock_guard wait(sync_dispatch_mu_);
}

void CanopenMaster::RunSync(Duration period, uint8_t overflow) {
  using SteadyTime = std::chrono::steady_clock::time_point;
  sync_thread_id_.store(std::this_thread::get_id());
  const std::chrono::steady_clock::duration step =
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
  SteadyTime next = std::chrono::steady_clock::now() + step;
  std::optional<SteadyTime> previous;
  uint8_t counter = 0;
  std::unique_lock lock(sync_mu_);
  while (!sync_cv_.wait_until(lock, next, [&] { return sync_stop_; })) {
    lock.unlock();
    // A timer that woke a whole period late skips the missed SYNCs instead of sending a burst
    // (decision 1116): nodes would see several SYNCs back to back.
    const SteadyTime woke = std::chrono::steady_clock::now();
    uint64_t skipped = 0;
    if (woke - next >= step) {
      skipped = static_cast<uint64_t>((woke - next) / step);
      next += step * static_cast<int64_t>(skipped);
    }
    Sync sync;
    if (overflow != 0) {
      counter = NextSyncCounter(counter, overflow);
      sync.counter = counter;
    }
    absl::StatusOr<transport::CanFrame> frame = EncodeSync(sync);
    bool sent = false;
    std::pair<uint64_t, uint64_t> flushed{0, 0};
    {
      // One SYNC cycle ends and the next begins atomically for SendRpdo; the held synchronous
      // RPDOs leave right after the SYNC, so the node acts on them at the next one.
      std::lock_guard pacing(rpdo_mu_);
      sent = frame.ok() && SendFrame(*frame).ok();
      if (sent) flushed = FlushSyncRpdosLocked();
    }
    const SteadyTime at = std::chrono::steady_clock::now();
    {
      std::lock_guard counters_lock(mu_);
      counters_.sync_overruns += skipped;
      counters_.rpdo_sent += flushed.first;
      counters_.rpdo_dropped += flushed.second;
      if (sent) {
        ++counters_.sync_sent;
        if (previous) {
          const Duration error = Abs(std::chrono::duration_cast<Duration>(at - *previous) - period);
          counters_.sync_last_period_error = error;
          counters_.sync_max_period_error = std::max(counters_.sync_max_period_error, error);
        }
      } else {
        ++counters_.sync_send_errors;
      }
    }
    if (sent) {
      previous = at;
      const SyncEvent event{sync.counter.value_or(0), std::chrono::time_point_cast<Duration>(at)};
      std::lock_guard dispatching(sync_dispatch_mu_);
      std::vector<std::pair<SyncListenerId, SyncListener>> listeners;
      {
        std::lock_guard l(sync_mu_);
        listeners.assign(sync_listeners_.begin(), sync_listeners_.end());
      }
      for (const auto& [id, listener] : listeners) {
        {
          // A stop request does not skip listeners: every SYNC that left gets its RPDOs.
          std::lock_guard l(sync_mu_);
          if (!sync_listeners_.contains(id)) continue;
        }
        listener(event);
      }
    }
    next += step;
    lock.lock();
  }
  lock.unlock();
  uint64_t dropped = 0;
  {
    std::lock_guard pacing(rpdo_mu_);
    dropped = EndSyncRpdosLocked();
  }
  {
    std::lock_guard counters_lock(mu_);
    counters_.rpdo_dropped += dropped;
  }
  sync_thread_id_.store(std::thread::id());
}

}  // namespace drivegw::canopen
