// CANopen master runtime over one CanChannel: NMT commands, SDO client (one transfer per node at a
// time, queued), PDO configuration and exchange, SYNC producer, heartbeat consumer, EMCY consumer
// and bus fault handling, shared by every drive on the bus (one receive thread, node observers).
// No drive family knowledge. Threading, queueing, heartbeat and SYNC choices: decisions
// docs/decisions/1111-1119; the protocol itself is the pure library next to this file (CiA 301
// v4.2.0).
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <shared_mutex>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/canopen/emcy.h"
#include "adapters/canopen/nmt.h"
#include "adapters/canopen/pdo.h"
#include "adapters/canopen/sdo.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_config.h"
#include "adapters/transport/can_channel.h"

namespace drivegw::canopen {

struct MasterOptions {
  // Per frame exchange: request sent → response received (decision 1103).
  Duration sdo_timeout = kSdoDefaultTimeout;
  // Bounded SDO retry (decision 1481): a retriable transfer (every upload; a download the caller
  // marks SdoRetry::kIdempotent) that got no response within sdo_timeout is aborted (0504 0000h,
  // CiA 301 §7.2.4.3.17) and started over from its initiate up to this many times. 0: one try.
  int sdo_retries = 0;
  size_t sdo_max_size = kSdoDefaultMaxSize;  // largest upload accepted (decision 1103)
  // Back-off while the bus is off, down or the channel is broken: doubling from min to max
  // (decision 1117).
  Duration bus_retry_min = std::chrono::milliseconds(100);
  Duration bus_retry_max = std::chrono::seconds(5);
  // Time source of SDO deadlines and heartbeat supervision; must outlive the master. The SYNC
  // producer always runs on the steady clock (decision 1116).
  const Clock* clock = &SteadyClock::Instance();
};

// May a download be repeated after a time-out (MasterOptions::sdo_retries)? Only when writing
// the same bytes twice leaves the node as writing them once: not for command objects such as
// 1010h "save" or a manufacturer's trigger (decision 1481). Uploads are always retriable.
enum class SdoRetry : uint8_t { kNo, kIdempotent };

// What a node observer is told besides heartbeats, EMCY and PDOs.
enum class NodeEvent : uint8_t {
  kHeartbeatLost,     // no heartbeat within the consumer time (1016h semantics, decision 1114)
  kHeartbeatResumed,  // a heartbeat after kHeartbeatLost
  kBootUp,            // boot-up message (00h): the node restarted and lost its configuration
  kBusOff,            // the gateway's controller is bus-off (SocketCAN)
  kLinkLost,          // the channel is down or broken; the master reopens it with back-off
  kLinkRestored,      // the bus works again after kBusOff / kLinkLost
};
// "heartbeat_lost", "heartbeat_resumed", "boot_up", "bus_off", "link_lost", "link_restored".
const char* NodeEventName(NodeEvent event);

struct NodeEventInfo {
  NodeEvent event = NodeEvent::kBootUp;
  uint8_t node = 0;
  TimePoint at{};
  std::string reason;  // for logs and the drive's error text
};

struct EmcyEvent {
  Emcy emcy;
  std::string name;  // EmcyCodeName: "EMCY 0x8611 following error"
  TimePoint at{};
};

struct TpdoEvent {
  uint8_t node = 0;
  uint16_t number = 1;  // TPDO 1..512
  uint16_t cob_id = 0;
  uint8_t size = 0;
  std::array<uint8_t, 8> data{};
  TimePoint at{};  // receive time (the master's clock)
  std::span<const uint8_t> payload() const { return {data.data(), size}; }
};

// A drive's view of its node. Every method is called on the master's receive thread without the
// master's lock held, one notification after the other: implementations must be quick (no
// blocking I/O, no waiting on other threads). They may call the non-blocking methods (SendRpdo,
// SendNmt, counters, node_state, Add/RemoveNodeObserver); the blocking SDO methods refuse to run
// on the receive thread (FailedPrecondition) because that thread delivers their answers.
class NodeObserver {
 public:
  virtual ~NodeObserver() = default;
  // Every heartbeat (not boot-up) of the node, with the NMT state it reports.
  virtual void OnHeartbeat(uint8_t /*node*/, NmtState /*state*/, TimePoint /*at*/) noexcept {}
  // The node's boot-up message (event kBootUp): re-configure it before using it again.
  virtual void OnBootUp(const NodeEventInfo& /*event*/) noexcept {}
  virtual void OnEmcy(const EmcyEvent& /*event*/) noexcept {}
  virtual void OnTpdo(const TpdoEvent& /*event*/) noexcept {}
  // kHeartbeatLost / kHeartbeatResumed of this node; kBusOff / kLinkLost / kLinkRestored go to
  // every observer.
  virtual void OnLinkEvent(const NodeEventInfo& /*event*/) noexcept {}
};

struct SyncEvent {
  uint8_t counter = 0;  // 1..overflow, 0 without counter (1019h = 0)
  TimePoint sent{};     // steady clock, right after the frame was handed to the channel
};
// Called on the SYNC thread right after each SYNC left (quick, like NodeObserver).
using SyncListener = std::function<void(const SyncEvent&)>;

// 1029h sub 1 "communication error" values (CiA 301 v4.2.0 §7.5.2.32).
enum class ErrorBehaviour : uint8_t {
  kPreOperational = 0,  // change to pre-operational (only from operational)
  kNoChange = 1,
  kStopped = 2,
};

struct MasterCounters {
  uint64_t frames_in = 0;    // every frame the channel returned
  uint64_t frames_out = 0;   // every frame handed to the channel successfully
  uint64_t send_errors = 0;  // Send failures
  uint64_t receive_errors = 0;
  // Frames for nobody here: other masters, nodes' SDO requests, extended-ID frames (CANopen uses
  // 11-bit identifiers), remote frames on a TPDO or error-control identifier (decision 1482).
  uint64_t other_traffic = 0;
  uint64_t error_frames = 0;  // error frames the controller reported (also in other_traffic)
  // EMCY / heartbeat frames that do not decode: wrong DLC, a state byte that is no NMT state,
  // an EMCY as remote frame (decision 1482).
  uint64_t malformed = 0;
  uint64_t nmt_sent = 0;
  uint64_t sdo_transfers = 0;        // completed successfully
  uint64_t sdo_failures = 0;         // completed with an error (any cause)
  uint64_t sdo_aborts_received = 0;  // server aborts
  uint64_t sdo_aborts_sent = 0;      // our abort frames (protocol violation, timeout, deadline)
  uint64_t sdo_timeouts = 0;         // per-frame time-outs and caller deadlines
  uint64_t sdo_unexpected = 0;       // SDO responses while no transfer of the node was running
  uint64_t sdo_retries = 0;          // transfers started over after a time-out (decision 1481)
  // With sdo_retries > 0: initiate answers and aborts naming another object than the running
  // transfer's while it waits for its initiate answer — a late answer to an earlier try, or a
  // duplicate — ignored rather than failing it (decision 1481).
  uint64_t sdo_stale_responses = 0;
  uint64_t sdo_queued_max = 0;  // most transfers waiting behind one node's active one
  uint64_t rpdo_sent = 0;
  // Synchronous RPDOs (decision 1118): frames held for a later SYNC cycle because the same RPDO
  // had already gone out in the current one, and held frames discarded (SYNC stopped, send
  // failed).
  uint64_t rpdo_deferred = 0;
  uint64_t rpdo_dropped = 0;
  uint64_t tpdo_received = 0;
  uint64_t sync_sent = 0;
  uint64_t sync_send_errors = 0;
  uint64_t sync_overruns = 0;         // periods skipped because the timer woke too late
  Duration sync_last_period_error{};  // |interval between the last two SYNCs - period|
  Duration sync_max_period_error{};   // the largest since StartSync
  uint64_t heartbeats = 0;
  uint64_t heartbeat_lost = 0;
  uint64_t own_heartbeats_sent = 0;  // this master's own heartbeat (StartOwnHeartbeat)
  uint64_t emcy = 0;
  uint64_t bootups = 0;
  uint64_t bus_off_events = 0;
  uint64_t link_lost_events = 0;
  uint64_t reopens = 0;  // channels reopened after a failure
};

using ObserverId = uint64_t;
using SyncListenerId = uint64_t;

// Every public method may be called from any thread (decision 1111). Deadlines are time points
// of options.clock.
class CanopenMaster {
 public:
  using Reopen = std::function<absl::StatusOr<std::unique_ptr<transport::CanChannel>>()>;

  // Opens the bus `bus` selects (transport::OpenCanChannel) and starts the receive thread; a
  // broken channel is reopened the same way.
  static absl::StatusOr<std::shared_ptr<CanopenMaster>> Open(const CanBusConfig& bus,
                                                             const MasterOptions& options = {});
  // The same on a channel the caller opened (tests inject faults through it); `reopen` (may be
  // empty: keep using `channel`) replaces a channel whose Receive failed.
  static absl::StatusOr<std::shared_ptr<CanopenMaster>> Open(
      std::unique_ptr<transport::CanChannel> channel, const MasterOptions& options = {},
      Reopen reopen = nullptr);
  ~CanopenMaster();
  CanopenMaster(const CanopenMaster&) = delete;
  CanopenMaster& operator=(const CanopenMaster&) = delete;

  // Stops SYNC and the receive thread; pending SDO transfers fail (Unavailable). Idempotent;
  // no observer or listener runs once it returned. Never from a callback or listener (it joins
  // their threads), so never drop the last shared_ptr there either.
  void Stop();

  // --- NMT (CiA 301 §7.2.8.3.1). node 0 = all nodes.
  absl::Status SendNmt(NmtCommand command, uint8_t node);

  // --- SDO client (blocking; not on the receive thread). `deadline` bounds the whole call
  // including the wait behind other transfers of the node; each frame exchange is bounded by
  // options.sdo_timeout. Errors name node and index:sub; server aborts carry the code
  // (AbortCodeOf) and its name, time-outs are DeadlineExceeded after abort 0504 0000h was sent.
  // Uploads, and downloads marked kIdempotent, are retried after a time-out (sdo_retries).
  absl::StatusOr<std::vector<uint8_t>> Upload(uint8_t node, uint16_t index, uint8_t sub,
                                              TimePoint deadline);
  absl::Status Download(uint8_t node, uint16_t index, uint8_t sub, std::span<const uint8_t> data,
                        TimePoint deadline, SdoRetry retry = SdoRetry::kNo);
  // Typed little-endian access. Reads accept exactly the width, or more bytes when the extra
  // ones are zero (an unsized expedited answer carries 4 bytes, decision 1112).
  absl::StatusOr<uint8_t> ReadU8(uint8_t node, uint16_t index, uint8_t sub, TimePoint deadline);
  absl::StatusOr<uint16_t> ReadU16(uint8_t node, uint16_t index, uint8_t sub, TimePoint deadline);
  absl::StatusOr<uint32_t> ReadU32(uint8_t node, uint16_t index, uint8_t sub, TimePoint deadline);
  absl::StatusOr<int32_t> ReadI32(uint8_t node, uint16_t index, uint8_t sub, TimePoint deadline);
  absl::Status WriteU8(uint8_t node, uint16_t index, uint8_t sub, uint8_t value, TimePoint deadline,
                       SdoRetry retry = SdoRetry::kNo);
  absl::Status WriteU16(uint8_t node, uint16_t index, uint8_t sub, uint16_t value,
                        TimePoint deadline, SdoRetry retry = SdoRetry::kNo);
  absl::Status WriteU32(uint8_t node, uint16_t index, uint8_t sub, uint32_t value,
                        TimePoint deadline, SdoRetry retry = SdoRetry::kNo);
  absl::Status WriteI32(uint8_t node, uint16_t index, uint8_t sub, int32_t value,
                        TimePoint deadline, SdoRetry retry = SdoRetry::kNo);

  // --- PDO (decision 1113). Runs MappingWrites (decision 1107) as SDO downloads in order; the
  // first failure stops it and names the step. Afterwards TPDO frames on the configured COB-ID
  // reach the node's observers as (node, number), and SendRpdo uses the configured RPDO COB-ID.
  absl::Status ConfigurePdo(uint8_t node, PdoKind kind, uint16_t number, const PdoCommParams& comm,
                            std::span<const PdoMappingEntry> mapping, TimePoint deadline);
  // One RPDO frame (payload 0..8 bytes) on the configured or predefined COB-ID. Non-blocking.
  // An RPDO configured synchronous (transmission type 0..240: the node acts on it at the next
  // SYNC, CiA 301 §7.2.2.1) while this master produces SYNC leaves at most once per SYNC cycle:
  // a second frame of it in the same cycle waits, in order with the node's later RPDOs, and
  // leaves right after the next SYNC, so no value is overwritten in the node's buffer before a
  // SYNC applied it (decision 1118). More than kMaxHeldSyncRpdos waiting frames of one node are
  // ResourceExhausted. Without this master's SYNC (none, or another producer) it leaves at once.
  absl::Status SendRpdo(uint8_t node, uint16_t number, std::span<const uint8_t> payload);
  static constexpr size_t kMaxHeldSyncRpdos = 32;

  // --- SYNC producer on its own steady-clock timer (decision 1116). counter_overflow: 0 = no
  // counter byte, 2..240 = counter 1..overflow (1019h). Restarts when already running.
  absl::Status StartSync(Duration period, uint8_t counter_overflow = 0);
  void StopSync();
  bool sync_running() const;
  SyncListenerId AddSyncListener(SyncListener listener);
  // When it returns the listener does not run and will not run again (unless called from the
  // listener itself, which is allowed).
  void RemoveSyncListener(SyncListenerId id);

  // --- Heartbeat (decision 1114). The consumer time of `node` (1016h semantics): supervision
  // starts with the first heartbeat; zero turns it off.
  absl::Status SetHeartbeatConsumer(uint8_t node, Duration consumer_time);
  // Writes the node's producer time 1017h and reads it back (FailedPrecondition on a mismatch).
  absl::Status ConfigureHeartbeatProducer(uint8_t node, uint16_t period_ms, TimePoint deadline);
  // Writes 1029h sub `sub` (1 = communication error: bus-off, heartbeat/guarding loss).
  absl::Status ConfigureErrorBehaviour(uint8_t node, ErrorBehaviour behaviour, TimePoint deadline,
                                       uint8_t sub = 1);
  // The last NMT state the node reported (heartbeat or boot-up), if any.
  std::optional<NmtState> node_state(uint8_t node) const;
  // This master's own heartbeat (decision 1483): 700h + own_node, one byte 05h OPERATIONAL,
  // every `period` from the receive thread, so the nodes' 1016h consumers notice a dead master.
  // The first call starts it; a later call with the same node keeps the running producer (the
  // first period holds, like the pool's first options); another node ID is FailedPrecondition
  // naming both.
  absl::Status StartOwnHeartbeat(uint8_t own_node, Duration period);
  // Writes the node's consumer heartbeat entry 1016h sub `sub` = (producer << 16) | time_ms and
  // reads it back (FailedPrecondition on a mismatch, like 1017h).
  absl::Status ConfigureHeartbeatConsumer(uint8_t node, uint8_t producer, uint16_t time_ms,
                                          TimePoint deadline, uint8_t sub = 1);

  // --- Observers. When RemoveNodeObserver returns, the observer is not called any more (also
  // from inside a callback). Off the receive thread it waits for a delivery in progress: do not
  // call it while holding a lock the observer's callbacks take.
  absl::StatusOr<ObserverId> AddNodeObserver(uint8_t node, NodeObserver* observer);
  void RemoveNodeObserver(ObserverId id);

  // Makes the receive thread re-read the clock now (a ManualClock moved).
  void Wake();

  MasterCounters counters() const;
  std::string bus_name() const;
  bool link_up() const;

  // Wire trace of node `node` (Drive::SetWireTrace): while set, every frame whose identifier
  // carries the node (predefined connection set, CiA 301 §7.3.3; configured TPDOs by their
  // COB-ID) is logged naming `drive`. An empty `drive` ends it.
  void SetNodeTrace(uint8_t node, const std::string& drive);
  // Names node `node` for round-trip metrics (wire::ObserveRoundTrip): every SDO transfer that
  // ends OK reports its time from the first frame sent to completion under `family`/`drive`
  // (queue waits excluded: they measure the caller, not the wire). Empty `drive`: not reported.
  void SetNodeLabel(uint8_t node, const std::string& family, const std::string& drive);

 private:
  struct SdoRequest {
    explicit SdoRequest(SdoClientTransfer t) : transfer(std::move(t)) {}
    SdoClientTransfer transfer;
    uint8_t node = 0;
    // "sdo upload 0x6041:00 node 5", for errors.
    std::string context() const;
    TimePoint deadline{};        // the caller's
    TimePoint frame_deadline{};  // the current exchange's
    TimePoint started_at{};      // first frame sent
    bool started = false;
    int retries_left = 0;  // further tries after a time-out (decision 1481)
    int tries = 1;
    absl::StatusOr<std::vector<uint8_t>> result = std::vector<uint8_t>();
    // 0 until `result` is final (stored with release after it). The caller waits on this word
    // alone, not on a condition variable bound to mu_: the completing receive thread holds mu_,
    // and a waiter woken through the condition variable would block on mu_ at once and need a
    // second wake-up (decision 1321).
    std::atomic<uint32_t> done{0};
  };
  struct Heartbeat {
    Duration consumer_time{};  // zero: not supervised
    enum class State : uint8_t { kWaiting, kAlive, kLost } state = State::kWaiting;
    TimePoint last{};
  };
  struct Node {
    std::deque<std::shared_ptr<SdoRequest>> sdo;  // front: active once started
    Heartbeat heartbeat;
    std::optional<NmtState> nmt;
    std::string family, drive;  // SetNodeLabel
    // The object of the last transfer that needed more than one try: until late_until an answer
    // to one of its earlier tries may still arrive, so a new transfer of the same object waits
    // rather than take such an answer for its own (decision 1481).
    std::optional<std::pair<uint16_t, uint8_t>> late_object;
    TimePoint late_until{};
  };
  struct Notification {
    enum class Kind : uint8_t { kHeartbeat, kBootUp, kEmcy, kTpdo, kLink } kind = Kind::kLink;
    uint8_t node = 0;  // 0: every observer
    NmtState state = NmtState::kBootUp;
    NodeEventInfo event;
    EmcyEvent emcy;
    TpdoEvent tpdo;
  };
  struct Observer {
    uint8_t node = 0;
    NodeObserver* observer = nullptr;
  };
  enum class BusFault : uint8_t { kNone, kBusOff, kDown, kBroken };

  CanopenMaster(std::unique_ptr<transport::CanChannel> channel, const MasterOptions& options,
                Reopen reopen);
  void Run();
  Duration ServiceLocked(TimePoint now);
  void HandleFrameLocked(const transport::CanFrame& frame, TimePoint now);
  void HandleSdoResponseLocked(uint8_t node, const transport::CanFrame& frame, TimePoint now);
  void HandleErrorControlLocked(const transport::CanFrame& frame, TimePoint now);
  void HandleEmcyLocked(const transport::CanFrame& frame, TimePoint now);
  void HandleTpdoLocked(uint8_t node, uint16_t number, const transport::CanFrame& frame,
                        TimePoint now);
  void CheckBusStateLocked(TimePoint now);
  void BusFaultLocked(BusFault fault, const std::string& reason, TimePoint now);
  void BusRestoredLocked(TimePoint now);
  void Dispatch();

  // SDO plumbing (master_sdo.cpp).
  absl::StatusOr<std::vector<uint8_t>> Transfer(uint8_t node, SdoClientTransfer transfer,
                                                TimePoint deadline, bool retriable);
  // The front transfer timed out and has tries left: starts it over (decision 1481).
  void RetrySdoLocked(Node& n, TimePoint now);
  // With retries on: a response naming another object than the waiting front transfer's.
  bool IsStaleSdoAnswerLocked(const Node& n, const transport::CanFrame& frame) const;
  // The front transfer waits for late answers to a retried transfer of its object.
  bool WaitsForLateAnswersLocked(const Node& n, TimePoint now) const;
  void ApplySdoStepLocked(Node& n, SdoStep step, TimePoint now);
  // Expires queued and active transfers; returns the node's next SDO deadline (or `next`).
  TimePoint ServiceSdoLocked(Node& n, TimePoint now, TimePoint next);
  void PumpSdoLocked(Node& n, TimePoint now);
  void CompleteSdoLocked(Node& n, absl::StatusOr<std::vector<uint8_t>> result);
  void FailAllSdoLocked(const absl::Status& status);
  absl::StatusOr<uint64_t> ReadUnsigned(uint8_t node, uint16_t index, uint8_t sub, size_t bytes,
                                        const char* type, TimePoint deadline);

  // SYNC producer (master_sync.cpp).
  void RunSync(Duration period, uint8_t overflow);
  // Synchronous RPDO pacing (master_sync_rpdo.cpp, decision 1118), all under rpdo_mu_.
  struct HeldRpdo {
    uint16_t number = 0;
    transport::CanFrame frame;
  };
  struct SyncRpdoNode {
    std::deque<HeldRpdo> held;  // waiting for a later SYNC cycle, in send order
    std::set<uint16_t> sent;    // RPDO numbers sent since the last SYNC
  };
  // A frame of a synchronous RPDO while SYNC runs: sent now or held (see SendRpdo).
  absl::Status SendSyncRpdoLocked(uint8_t node, uint16_t number, const transport::CanFrame& frame,
                                  const std::string& what, bool& deferred);
  // Right after a SYNC left: a new cycle; sends held frames, at most one per RPDO and node.
  // Returns {sent, dropped}.
  std::pair<uint64_t, uint64_t> FlushSyncRpdosLocked();
  // SYNC stopped: held frames are dropped (returned count), pacing ends.
  uint64_t EndSyncRpdosLocked();

  // Any thread, with or without mu_ (lock order: mu_, then channel_mu_).
  absl::Status SendFrame(const transport::CanFrame& frame);
  // Logs `frame` for the traced node it carries (SetNodeTrace); `node` 0: from the identifier.
  void TraceFrame(const transport::CanFrame& frame, const char* dir, uint8_t node = 0);
  void WakeReceiver();
  bool OnReceiveThread() const { return std::this_thread::get_id() == receive_thread_id_.load(); }
  bool HasObserverLocked(uint8_t node) const;

  const MasterOptions options_;
  const Clock& clock_;
  const Reopen reopen_;

  // The channel: only the receive thread replaces it (exclusive lock); senders hold it shared.
  mutable std::shared_mutex channel_mu_;
  std::unique_ptr<transport::CanChannel> channel_;
  std::string bus_name_;

  mutable std::mutex mu_;  // everything below
  std::condition_variable stop_cv_;
  bool stopping_ = false;
  BusFault fault_ = BusFault::kNone;
  Duration backoff_{};
  TimePoint planned_wake_{};
  std::map<uint8_t, Node> nodes_;
  std::map<ObserverId, Observer> observers_;
  ObserverId next_observer_ = 1;
  std::map<std::pair<uint8_t, uint16_t>, uint16_t> rpdo_cob_;     // (node, n) → COB-ID, 0 invalid
  std::set<std::pair<uint8_t, uint16_t>> rpdo_synchronous_;       // configured type 0..240
  std::map<std::pair<uint8_t, uint16_t>, uint16_t> tpdo_cob_;     // configured; 0 = invalid
  std::map<uint16_t, std::pair<uint8_t, uint16_t>> tpdo_by_cob_;  // configured and valid
  std::vector<Notification> pending_;  // filled under mu_, delivered by Dispatch
  uint8_t own_node_ = 0;               // own heartbeat producer: 0 = off (decision 1483)
  Duration own_period_{};
  TimePoint next_own_heartbeat_{};
  MasterCounters counters_;  // except frames_out / send_errors

  std::atomic<bool> tracing_{false};
  mutable std::mutex trace_mu_;                  // below; taken alone, never around a send
  std::map<uint8_t, std::string> traced_nodes_;  // node -> drive name
  std::atomic<uint64_t> frames_out_{0};
  std::atomic<uint64_t> send_errors_{0};
  std::atomic<std::thread::id> receive_thread_id_{};

  std::mutex dispatch_mu_;  // held by the receive thread while it delivers notifications

  // SYNC producer.
  mutable std::mutex sync_mu_;  // the thread handle and the listeners
  std::condition_variable sync_cv_;
  bool sync_stop_ = false;
  std::thread sync_thread_;
  std::map<SyncListenerId, SyncListener> sync_listeners_;
  SyncListenerId next_sync_listener_ = 1;
  std::mutex sync_dispatch_mu_;  // held by the SYNC thread while it calls listeners
  std::atomic<std::thread::id> sync_thread_id_{};
  std::mutex sync_control_mu_;  // serialises StartSync / StopSync
  // Synchronous RPDO pacing. Taken before channel_mu_ (SendFrame), never together with mu_. The
  // SYNC thread holds it while it sends a SYNC, so "sent in this cycle" is exact.
  std::mutex rpdo_mu_;
  bool sync_pacing_ = false;  // this master's SYNC producer runs
  std::map<uint8_t, SyncRpdoNode> sync_rpdo_;

  std::mutex stop_mu_;
  std::thread thread_;
};

}  // namespace drivegw::canopen
