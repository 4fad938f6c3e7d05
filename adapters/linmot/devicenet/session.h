// DeviceNet master (scanner) session: one CAN channel per bus and one I/O thread for every LinMot
// DeviceNet drive on it — own duplicate MAC ID check, allocation of the predefined master/slave
// connection set, expected packet rate, poll cycle (fragmented when > 8 bytes), the 4 x EPR
// inactivity watchdog and reconnection (linmot-devicenet.md §5.5-§5.8, §10.2, §11.2, §11.3,
// §11.8, §11.9; decisions docs/decisions/980-989). What goes into a poll is the peer's job.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/health.h"
#include "adapters/linmot/devicenet/codec.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::linmot::devicenet {

// Exchange counters of one drive, for the dashboard; summed over every drive per session.
struct PeerCounters {
  uint64_t frames_sent = 0;        // every frame for this drive (fragments, explicit, polls)
  uint64_t frames_received = 0;    // every frame from this drive the session consumed
  uint64_t polls_sent = 0;         // poll command messages (a fragmented one counts once)
  uint64_t poll_responses = 0;     // complete poll responses of the produced size
  uint64_t poll_timeouts = 0;      // polls without a response within response_timeout
  uint64_t explicit_requests = 0;  // Allocate, Release, Get/Set_Attribute_Single, keep-alives
  uint64_t explicit_errors = 0;    // 0x94 error responses (§5.3)
  uint64_t explicit_timeouts = 0;  // explicit requests without a response
  uint64_t fragment_errors = 0;    // fragments out of order / missing (§5.8): message dropped
  uint64_t size_mismatches = 0;    // responses of another length than produced_size (D-24)
  uint64_t unsolicited = 0;        // responses nobody waited for (late, wrong XID, no connection)
  uint64_t foreign_master = 0;     // another master's requests or responses for this drive
  uint64_t watchdog_expiries = 0;  // 4 x EPR without a poll response (§5.6)
  uint64_t connects = 0;           // I/O connection established (set-up completed)
  uint64_t drive_restarts = 0;     // the drive's duplicate MAC ID check seen while connected
  uint64_t send_errors = 0;        // Send failures (bus off, full queue)
  std::optional<double> last_round_trip_ms;  // last explicit request's (not summed)
};

struct SessionCounters {
  PeerCounters total;                   // over every drive ever registered
  uint64_t frames_sent = 0;             // the session's own frames (duplicate MAC ID check)
  uint64_t frames_received = 0;         // every frame the channel returned
  uint64_t malformed = 0;               // not a DeviceNet frame or undecodable: counted, dropped
  uint64_t unexpected_mac = 0;          // slave frames from a MAC ID no drive is registered for
  uint64_t other_traffic = 0;           // valid frames between other nodes
  uint64_t duplicate_mac_detected = 0;  // the gateway's own MAC ID is in use (§5.7)
  uint64_t duplicate_mac_answered = 0;  // other nodes' checks of our MAC ID, answered
  uint64_t bus_off_events = 0;          // channel reported bus-off / down
  uint64_t receive_errors = 0;          // channel errors while receiving (the loop goes on)
};

enum class LinkState { kUnknown, kOnline, kOffline };
const char* ToString(LinkState s);

// Session-wide settings: the gateway is one node on the bus.
struct SessionOptions {
  uint8_t master_mac = 0;  // the gateway's MAC ID (§0.4 example, decision 981)
  // §5.7 [SPEC-M]: two duplicate MAC ID requests this far apart; online if both go unanswered.
  Duration duplicate_check_wait = std::chrono::seconds(1);
  uint16_t vendor_id = 0;               // in our duplicate MAC ID frames (no ODVA vendor ID yet)
  uint32_t serial_number = 0x44475700;  // "DGW" + 0: project value, decision 981
  // Back-off while the bus is off or down, or our MAC ID is taken.
  Duration bus_retry_min = std::chrono::milliseconds(100);
  Duration bus_retry_max = std::chrono::seconds(5);
};

// One drive (slave) on the bus.
struct PeerOptions {
  std::string name;          // drive name, for logs
  uint8_t mac_id = 5;        // 0..63, not the gateway's
  size_t consumed_size = 6;  // poll command bytes (§7.7); fragmented when > 8 (§5.8)
  size_t produced_size = 8;  // poll response bytes
  Duration poll_period = std::chrono::milliseconds(10);       // D-33
  Duration response_timeout = std::chrono::milliseconds(50);  // poll response
  uint16_t expected_packet_rate_ms = 100;  // poll connection EPR; must exceed poll_period (§11.3)
  uint16_t explicit_epr_ms = 2500;         // explicit connection EPR (§11.2 step 5)
  Duration explicit_timeout = std::chrono::milliseconds(200);
  Duration retry_min = std::chrono::milliseconds(100);  // set-up back-off, doubling ...
  Duration retry_max = std::chrono::seconds(2);         // ... up to this
  Duration restart_wait = std::chrono::seconds(2);      // §11.8: drive restarted, wait >= 2 s
  // Consecutive poll time-outs that end the connection as DOWN (health.down_after_failures,
  // decision 1431). 0 = one more than fit into the inactivity watchdog (4 x EPR /
  // response_timeout), so by default the watchdog decides, as before the shared model.
  int down_after_failures = 0;
  // DEMOTED -> UP only after this long without a poll time-out (health.up_after_ms, decision
  // 1432).
  std::chrono::milliseconds up_after{kDefaultUpAfter};
  // Wire trace switch (Drive::SetWireTrace): while it reads true, every frame to and from this
  // MAC ID is logged (adapters/core/wire_observer.h). Null: never.
  std::shared_ptr<const std::atomic<bool>> wire_trace;
};

// The drive side of a registration. Called on the session's I/O thread while the session holds
// its lock: implementations must be quick, must not block on the bus, and must never call back
// into the Session (Register/Unregister/counters) from a callback.
class SessionPeer {
 public:
  virtual ~SessionPeer() = default;
  // The consumed image (master -> drive) for the next poll; exactly consumed_size bytes.
  virtual std::vector<uint8_t> BuildPollCommand() noexcept = 0;
  // A complete poll response of produced_size bytes (reassembled if fragmented).
  virtual void OnPollResponse(std::span<const uint8_t> produced, TimePoint received) noexcept = 0;
  // True when the peer changed its image (a command waits): the poll leaves at once instead of at
  // the next period (docs/decisions/006-commands-leave-at-once.md).
  virtual bool HasUrgentRequest() noexcept { return false; }
  // A poll went unanswered for response_timeout.
  virtual void OnPollTimeout() noexcept {}
  // kOnline on the first poll response of a new I/O connection; kOffline when the connection is
  // lost (watchdog, bus-off, drive restart, unregister). After kOffline the next connection starts
  // from a fresh image: the peer must drop whatever command it had (never replayed, decision 983).
  virtual void OnLinkChange(LinkState state, const std::string& reason) noexcept = 0;
  // The peer's HealthModel info changed (decision 1431); same rules as the other callbacks.
  virtual void OnHealthChange(const HealthInfo& health) noexcept { (void)health; }
};

using PeerId = uint64_t;

class Session {
 public:
  // Opens the bus `bus` selects (transport::OpenCanChannel) and starts the I/O thread; the
  // duplicate MAC ID check of the gateway's MAC begins at once. `clock` must advance in real time
  // (the channel waits in real time) and outlive the session.
  static absl::StatusOr<std::shared_ptr<Session>> Open(const CanBusConfig& bus,
                                                       const SessionOptions& options,
                                                       const Clock& clock);
  // The same on a channel the caller opened (tests inject faults through it).
  static absl::StatusOr<std::shared_ptr<Session>> Open(
      std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options,
      const Clock& clock);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Adds a drive; its connection set-up starts as soon as the bus is online. InvalidArgument for
  // a MAC ID above 63 or equal to the gateway's, sizes of 0 or above the fragmentation limit, a
  // poll period below 1 ms, an EPR not above the poll period; AlreadyExists when another drive
  // uses the MAC ID; FailedPrecondition after Stop.
  absl::StatusOr<PeerId> Register(const PeerOptions& options, SessionPeer* peer);
  // Removes a drive and releases its connection set (§11.9: Release on Group 2 msg 6). When it
  // returns no callback of that peer runs or will run. Unknown ids are ignored.
  void Unregister(PeerId id);

  // Wakes the I/O thread so that a peer's urgent image leaves now (decision 006). Lock-free.
  void Expedite() { channel_->Wake(); }

  // Stops the I/O thread; idempotent, also done by the destructor. Peers get no callbacks after.
  void Stop();

  std::string bus_name() const { return channel_->name(); }
  uint8_t master_mac() const { return options_.master_mac; }
  // True once the gateway's duplicate MAC ID check passed and the bus is not off.
  bool bus_online() const;
  SessionCounters counters() const;
  std::optional<PeerCounters> peer_counters(PeerId id) const;
  std::optional<LinkState> link_state(PeerId id) const;
  size_t peer_count() const;
  transport::CanCounters channel_counters() const { return channel_->counters(); }

 private:
  // Connection set-up steps (§11.2) and the established state.
  enum class Step {
    kWaitBus,       // bus not online yet
    kBackoff,       // retry at retry_at
    kRelease,       // Release outstanding (before a re-allocation, §11.8)
    kAllocate,      // Allocate explicit + polled outstanding (§5.5)
    kExplicitEpr,   // Set EPR of instance 1 (§11.2 step 5)
    kProducedSize,  // Get attr 7 of instance 2 (optional, D-13)
    kConsumedSize,  // Get attr 8 of instance 2 (optional)
    kPollEpr,       // Set EPR of instance 2 (§11.2 step 6)
    kEstablished,   // polling
  };
  enum class BusState { kChecking, kOnline, kDuplicate, kDown };

  struct Explicit {  // the one outstanding explicit request of a peer
    uint8_t service = 0;
    bool xid = false;
    TimePoint deadline{};
    bool keep_alive = false;
  };
  struct Peer {
    PeerOptions options;
    SessionPeer* peer = nullptr;
    PredefinedIds ids{};
    PeerCounters counters;
    LinkState link = LinkState::kUnknown;
    Step step = Step::kWaitBus;
    TimePoint retry_at{};
    Duration backoff{};
    // Poll time-out counting, DOWN and the set-up back-off (decision 1431); set by Register.
    std::optional<HealthModel> health;
    bool release_first = false;  // the next set-up starts with a Release
    bool warned_setup = false;   // set-up failure logged at warn once per outage
    bool warned_foreign = false;
    bool xid = false;
    std::optional<Explicit> pending_explicit;
    uint16_t granted_epr_ms = 0;
    uint16_t granted_explicit_epr_ms = 0;
    TimePoint next_keep_alive{};
    bool poll_outstanding = false;
    TimePoint poll_deadline{};
    TimePoint next_poll{};
    TimePoint last_response{};
    Reassembler reassembler;
  };

  Session(std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options,
          const Clock& clock);
  void Run();
  Duration ServiceLocked(TimePoint now);
  Duration ServiceBusLocked(TimePoint now);
  void ServicePeerLocked(Peer& p, TimePoint now);
  void HandleFrameLocked(const transport::CanFrame& raw, TimePoint now);
  void HandleDuplicateMacLocked(uint8_t mac, std::span<const uint8_t> data, TimePoint now);
  void HandleExplicitResponseLocked(Peer& p, std::span<const uint8_t> data, TimePoint now);
  void HandlePollResponseLocked(Peer& p, std::span<const uint8_t> data, TimePoint now);
  void OnExplicitResultLocked(Peer& p, const Explicit& request,
                              const std::optional<ExplicitResponse>& response, TimePoint now);

  void SendExplicitLocked(Peer& p, const ExplicitRequest& request, uint16_t id, TimePoint now,
                          bool keep_alive = false);
  void SendPollLocked(Peer& p, TimePoint now);
  bool SendFrameLocked(const Frame& frame, PeerCounters* counters);
  // Logs `frame` when the drive with `mac` has its wire trace on.
  void TraceLocked(uint8_t mac, const char* dir, const Frame& frame);
  void StartSetupLocked(Peer& p, TimePoint now);
  void FailSetupLocked(Peer& p, TimePoint now, const std::string& why, bool release_first);
  void EstablishLocked(Peer& p, TimePoint now);
  void SetLinkLocked(Peer& p, LinkState to, const std::string& reason);
  void DropConnectionLocked(Peer& p, TimePoint now, const std::string& reason, Duration wait,
                            bool release_first);
  void BusLostLocked(TimePoint now, const std::string& reason);
  // Hands a changed health to the peer.
  static void HealthChangedLocked(Peer& p, bool changed);
  Peer* FindByMacLocked(uint8_t mac);

  const SessionOptions options_;
  const Clock& clock_;
  std::unique_ptr<transport::CanChannel> channel_;

  mutable std::mutex mu_;  // everything below; held during peer callbacks
  std::condition_variable stop_cv_;
  bool stopping_ = false;
  BusState bus_ = BusState::kChecking;
  int checks_sent_ = 0;
  TimePoint bus_next_{};
  Duration bus_backoff_{};
  PeerId next_id_ = 1;
  std::map<PeerId, Peer> peers_;
  SessionCounters counters_;
  std::mutex stop_mu_;
  std::thread thread_;
};

// Process-wide registry handing out one Session per bus (the spec string of the CanBusConfig), so
// every drive on the same bus shares one channel and one I/O thread. A Session lives as long as a
// drive holds it. The options of the first drive open the session; a later drive asking for a
// different gateway MAC ID on the same bus is refused (FailedPrecondition naming both).
class SessionPool {
 public:
  static SessionPool& Instance();
  absl::StatusOr<std::shared_ptr<Session>> Acquire(const CanBusConfig& bus,
                                                   const SessionOptions& options,
                                                   const Clock& clock);

 private:
  std::mutex mu_;
  std::map<std::string, std::weak_ptr<Session>> sessions_;
};

}  // namespace drivegw::linmot::devicenet
