// Drive collector and round-trip sink (drive_metrics.h).
#include "server/ops/drive_metrics.h"

#include <chrono>
#include <map>
#include <mutex>
#include <string>
#include <utility>

#include "adapters/core/wire_observer.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/linmot/linudp/drive.h"
#include "adapters/stober/drive.h"
#include "adapters/trinamic/drive.h"

namespace drivegw::ops {
namespace {

constexpr char kRequests[] = "drivegw_drive_wire_requests_total";
constexpr char kRequestsHelp[] =
    "Requests this drive's session put on the wire (LinUDP telegrams, DeviceNet polls and explicit "
    "requests, Trinamic words, STOBER RPDOs).";
constexpr char kReplies[] = "drivegw_drive_wire_replies_total";
constexpr char kRepliesHelp[] =
    "Valid replies matched to a request (LinUDP replies, DeviceNet poll responses, Trinamic axis "
    "samples, STOBER status and actual-value TPDOs).";
constexpr char kErrors[] = "drivegw_drive_wire_errors_total";
constexpr char kErrorsHelp[] = "Exchange errors of this drive's session, by kind.";

struct Out {
  std::vector<CollectedSample>& samples;
  const std::string& drive;
  const std::string& family;

  void Add(const char* name, const char* help, MetricType type, double v, Labels extra = {}) {
    Labels l = std::move(extra);
    l["drive"] = drive;
    l["family"] = family;
    samples.push_back({name, help, type, std::move(l), v});
  }
  void Requests(uint64_t v) { Add(kRequests, kRequestsHelp, MetricType::kCounter, double(v)); }
  void Replies(uint64_t v) { Add(kReplies, kRepliesHelp, MetricType::kCounter, double(v)); }
  void Error(const char* kind, uint64_t v) {
    Add(kErrors, kErrorsHelp, MetricType::kCounter, double(v), {{"kind", kind}});
  }
};

void CollectLinUdp(const linmot::linudp::LinMotUdpDrive& d, Out& o) {
  const auto c = d.exchange_counters();
  if (!c) return;
  o.Requests(c->telegrams_sent);
  o.Replies(c->replies);
  o.Error("timeout", c->timeouts);
  o.Error("send", c->send_errors);
  o.Error("malformed", c->malformed);
  o.Error("late", c->late);
  o.Error("header_mismatch", c->header_mismatch);
  // Decision 1461: a reordered telegram re-executed a superseded motion command.
  o.Error("stale_motion", d.stale_motion_commands());
}

void CollectDeviceNet(const linmot::devicenet::LinMotDnDrive& d, Out& o) {
  const auto c = d.exchange_counters();
  if (!c) return;
  o.Requests(c->polls_sent + c->explicit_requests);
  o.Replies(c->poll_responses);
  o.Error("timeout", c->poll_timeouts + c->explicit_timeouts);
  o.Error("explicit_error", c->explicit_errors);
  o.Error("fragment", c->fragment_errors);
  o.Error("size_mismatch", c->size_mismatches);
  o.Error("send", c->send_errors);
  o.Error("watchdog", c->watchdog_expiries);
}

void CollectTrinamic(const trinamic::TrinamicDrive& d, Out& o) {
  const trinamic::TrinamicDriveCounters c = d.counters();
  o.Requests(c.words);
  o.Replies(c.samples);
  o.Error("accept_failure", c.accept_failures);
}

void CollectStober(const stober::StoberDrive& d, Out& o) {
  const stober::StoberDriveCounters c = d.counters();
  o.Requests(c.rpdos);
  o.Replies(c.status_tpdos + c.actual_tpdos);
  o.Error("configure", c.configure_failures);
  o.Error("heartbeat_lost", c.heartbeat_losses);
  o.Error("emcy", c.emcy);
  o.Error("execute_retry", c.execute_retries);
  o.Error("malformed", c.malformed_tpdos);
  // Cycle lateness of the bus's SYNC producer (decision 1118): skipped periods and how far the
  // last and worst intervals were off the period.
  if (const auto m = d.master_counters()) {
    o.Add("drivegw_sync_overruns_total", "SYNC periods skipped because the timer woke too late.",
          MetricType::kCounter, double(m->sync_overruns));
    o.Add("drivegw_sync_period_error_seconds",
          "Deviation of the last interval between two SYNCs from the period.", MetricType::kGauge,
          std::chrono::duration<double>(m->sync_last_period_error).count());
    o.Add("drivegw_sync_period_error_max_seconds",
          "Largest deviation of a SYNC interval from the period since SYNC started.",
          MetricType::kGauge, std::chrono::duration<double>(m->sync_max_period_error).count());
  }
}

void CollectDrive(const Drive& drive, std::vector<CollectedSample>& samples) {
  const DriveConfig& cfg = drive.config();
  Out o{samples, cfg.name, cfg.family};
  const DriveStatus st = drive.GetStatus();
  o.Add("drivegw_drive_online", "1 while the drive answers (state not OFFLINE).",
        MetricType::kGauge, st.state == DriveState::kOffline ? 0 : 1);
  o.Add("drivegw_drive_fault", "1 while the drive reports a fault.", MetricType::kGauge,
        st.state == DriveState::kFault || st.fault.code != 0 ? 1 : 0);
  o.Add("drivegw_drive_active", "1 while the drive's lifecycle is ACTIVE.", MetricType::kGauge,
        drive.lifecycle() == Lifecycle::kActive ? 1 : 0);
  if (auto* d = dynamic_cast<const linmot::linudp::LinMotUdpDrive*>(&drive)) {
    CollectLinUdp(*d, o);
  } else if (auto* d = dynamic_cast<const linmot::devicenet::LinMotDnDrive*>(&drive)) {
    CollectDeviceNet(*d, o);
  } else if (auto* d = dynamic_cast<const trinamic::TrinamicDrive*>(&drive)) {
    CollectTrinamic(*d, o);
  } else if (auto* d = dynamic_cast<const stober::StoberDrive*>(&drive)) {
    CollectStober(*d, o);
  }
}

// Round trips: one histogram per (family, drive), looked up once and kept.
void RoundTripSink(std::string_view family, std::string_view drive, double seconds) {
  static std::mutex mu;
  static std::map<std::pair<std::string, std::string>, Histogram*> cache;
  Histogram* h = nullptr;
  {
    std::lock_guard lock(mu);
    auto key = std::make_pair(std::string(family), std::string(drive));
    auto it = cache.find(key);
    if (it == cache.end()) {
      Histogram& created = DefaultRegistry().GetHistogram(
          "drivegw_wire_round_trip_seconds",
          "Request to reply on the wire: LinUDP telegram, DeviceNet explicit message, Trinamic "
          "instruction (per controller line), CANopen SDO transfer (first frame to completion).",
          LatencyBuckets(), {{"family", key.first}, {"drive", key.second}});
      it = cache.emplace(std::move(key), &created).first;
    }
    h = it->second;
  }
  h->Observe(seconds);
}

}  // namespace

int AddDriveCollector(Registry& registry, std::vector<std::shared_ptr<Drive>> drives) {
  return registry.AddCollector([drives = std::move(drives)](std::vector<CollectedSample>& out) {
    for (const auto& d : drives) CollectDrive(*d, out);
  });
}

void InstallRoundTripHistograms() { wire::SetRoundTripSink(&RoundTripSink); }

}  // namespace drivegw::ops
