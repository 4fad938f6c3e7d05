// LinUDP master session: one UDP socket per local endpoint, one I/O thread running the cyclic
// request/reply exchange with every registered drive (linmot-linudp.md §6, A-01, A-02, A-06,
// Bytes <-> structs stay in codec.h; what goes into a telegram is the peer's job.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/health.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/transport/endpoint.h"
#include "adapters/transport/thread_scheduling.h"
#include "adapters/transport/udp_socket.h"

namespace drivegw::linmot::linudp {

// Exchange counters, for the dashboard. Per peer and summed per session.
struct ExchangeCounters {
  uint64_t telegrams_sent = 0;   // requests handed to the socket (send errors included)
  uint64_t send_errors = 0;      // SendTo failures (the request then times out)
  uint64_t replies = 0;          // valid replies matched to an outstanding request
  uint64_t timeouts = 0;         // requests without a valid reply within reply_timeout
  uint64_t malformed = 0;        // undecodable, short or missing asked-for blocks
  uint64_t late = 0;             // datagrams from the drive while no request was outstanding
  uint64_t header_mismatch = 0;  // bytes 0-3 differ from the request definition (A-02: logged only)
  // Cycle periods on the peer's fixed grid (registration time + k * cycle) that have ended, and
  // those of them without a completed exchange: a period is met when a request sent at or after
  // its start got its valid reply before its end (A-07: one exchange per period). Late periods
  // are what issue 10 (P2) counts against the cycle time.
  uint64_t cycles = 0;
  uint64_t late_cycles = 0;
  // Late periods that overlap a stall of the session's own I/O thread (SessionCounters::
  // io_stalls): the thread was not running, so the cause is the host's scheduling (priority,
  // other load, a hypervisor), not the network or the drive (decision 1312).
  uint64_t late_cycles_stalled = 0;
  std::optional<double> last_round_trip_ms;  // per peer only (not summed)
};

struct SessionCounters {
  ExchangeCounters total;       // sum over every peer ever registered
  uint64_t unknown_source = 0;  // datagrams from an endpoint no peer is registered for
  uint64_t receive_errors = 0;  // socket errors while receiving (the loop goes on)
  // Stalls of the I/O thread longer than kStallThreshold (500 us): a wake-up that late after the
  // moment it asked to wake, or a turn of the loop whose wall time exceeds the thread's CPU time
  // by that much. Either way the thread was held off the CPU (decision 1312).
  uint64_t io_stalls = 0;
  double io_stalled_ms = 0;  // their summed length (wake-up lateness or the whole turn)
};

enum class LinkState { kUnknown, kOnline, kOffline };
const char* ToString(LinkState s);

// The drive side of a registration. Called on the session's I/O thread while the session holds
// its registration lock: implementations must be quick, must not block on the network and must
// never call back into the Session (Register/Unregister/counters) from inside a callback.
class SessionPeer {
 public:
  virtual ~SessionPeer() = default;
  // The next telegram for this drive (A-04: the codec sends complete blocks). The session adds
  // nothing; the response definition asked for here is what A-02 checks the reply against.
  virtual Request BuildRequest() noexcept = 0;
  // A valid reply to the outstanding request, with the time it was received.
  virtual void OnReply(const Reply& reply, TimePoint received) noexcept = 0;
  // True when the peer has a new command waiting (control word, MC or RTC block): the session
  // then sends at once instead of at the next cycle (docs/decisions/006-commands-leave-at-once.md).
  virtual bool HasUrgentRequest() noexcept { return false; }
  // A request went unanswered for reply_timeout.
  virtual void OnTimeout() noexcept {}
  // kOnline on the first reply and on recovery, kOffline after lost_after_timeouts consecutive
  // time-outs.
  virtual void OnLinkChange(LinkState state) noexcept = 0;
  // The peer's HealthModel info changed (decision 1431): UP/DEMOTED/DOWN, count, reason. Same
  // rules as the other callbacks; DriveBase::SetHealth qualifies (it takes a leaf lock only).
  virtual void OnHealthChange(const HealthInfo& health) noexcept { (void)health; }
};

struct PeerOptions {
  std::string name;            // drive name, for logs
  transport::Endpoint remote;  // the drive: replies are routed by this ip:port
  std::chrono::milliseconds cycle{5};
  std::chrono::milliseconds reply_timeout{50};
  int lost_after_timeouts = 5;  // health.down_after_failures (decision 1431)
  // Probe back-off of a DOWN drive (health.backoff_min_ms / backoff_max_ms, decision 1431):
  // 0 = a telegram every cycle, as before the shared model (the drive has its own ip:port, so
  // probing it costs the others nothing but a datagram).
  std::chrono::milliseconds probe_backoff_min{0};
  std::chrono::milliseconds probe_backoff_max{0};
  // DEMOTED -> UP only after this long without a time-out (health.up_after_ms, decision 1432).
  std::chrono::milliseconds up_after{kDefaultUpAfter};
  // Wire trace switch (Drive::SetWireTrace): while it reads true, every telegram to and from
  // this drive is logged as hex (adapters/core/wire_observer.h). Null: never.
  std::shared_ptr<const std::atomic<bool>> wire_trace;
};

using PeerId = uint64_t;

class Session {
 public:
  // Every peer's cycle periods start on this grid (relative to the session's epoch), so that
  // drives registered at slightly different moments share due times: the I/O thread then wakes
  // a few times per cycle and sends each group with one sendmmsg instead of waking once per
  // drive (issue 10, P2). The first telegram still leaves at once (Register), so its period
  // began up to one tick earlier: period k's telegram leaves at most one tick before
  // registration + k cycles.
  static constexpr Duration kGridTick = std::chrono::microseconds(250);

  // Binds `local` and starts the I/O thread with `scheduling` (linudp.io_priority / io_cpus,
  // decision 1311). `clock` must advance in real time (the socket waits in real time) and
  // outlive the session. A scheduling the system refuses fails the open (PermissionDenied
  // without CAP_SYS_NICE), it is never dropped silently.
  static absl::StatusOr<std::shared_ptr<Session>> Open(
      const transport::Endpoint& local, const Clock& clock,
      const transport::ThreadScheduling& scheduling = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Adds a drive to the cyclic exchange; its first telegram leaves at once. InvalidArgument for
  // a cycle below 1 ms, a non-positive reply time-out or lost_after_timeouts < 1;
  // AlreadyExists when another peer already uses `options.remote` (replies could not be told
  // apart); FailedPrecondition after Stop.
  absl::StatusOr<PeerId> Register(const PeerOptions& options, SessionPeer* peer);
  // Removes a drive. When it returns, no callback of that peer runs or will run. Unknown ids
  // are ignored.
  void Unregister(PeerId id);

  // Wakes the I/O thread so that peer `id`'s urgent request leaves without waiting for its cycle
  // (still one outstanding request per drive, A-07): the peer is asked HasUrgentRequest at once
  // if it is idle, else on its reply. Callable from any thread with any lock held (it takes only
  // a leaf lock of its own).
  void Expedite(PeerId id);
  // Sends peer `id`'s urgent request from the calling thread when the line is free (A-07: no
  // request outstanding) and the session lock is free at once, so a command does not wait for the
  // I/O thread to wake (decision 1301). True when that is settled: sent now, or a request is
  // outstanding and the urgent one leaves on its reply (HandleDatagramLocked). False when the
  // I/O thread holds the lock or the peer is unknown: the caller then calls Expedite. The caller
  // must not hold the peer's own lock (lock order: session lock -> peer lock).
  bool SendUrgentNow(PeerId id);

  // Stops the I/O thread (wakes it and joins) and shuts the socket; idempotent, also done by the
  // destructor. Peers get no further callbacks.
  void Stop();

  // The bound address (with the kernel's port when opened with port 0).
  transport::Endpoint local_endpoint() const { return local_; }
  const transport::ThreadScheduling& scheduling() const { return scheduling_; }
  SessionCounters counters() const;
  std::optional<ExchangeCounters> peer_counters(PeerId id) const;
  std::optional<LinkState> link_state(PeerId id) const;
  size_t peer_count() const;

 private:
  struct Peer {
    PeerId id = 0;
    PeerOptions options;
    SessionPeer* peer = nullptr;
    ExchangeCounters counters;
    LinkState link = LinkState::kUnknown;
    int consecutive_timeouts = 0;
    // Counting, state and probe back-off (decision 1431); set by Register.
    std::optional<HealthModel> health;
    bool outstanding = false;
    uint32_t asked_response = 0;  // response definition of the outstanding request
    uint32_t sent_request = 0;    // request definition of the outstanding request
    TimePoint next_send{};        // start of the next cycle period: the next cyclic telegram
    TimePoint reply_deadline{};
    TimePoint sent_at{};       // when the outstanding (or last) request left
    TimePoint period_start{};  // start of the current cycle period (fixed grid)
    bool period_met = false;   // the current period saw a completed exchange
    // The one live entry of this peer in timers_ (older entries carry an older seq).
    bool armed = false;
    TimePoint armed_due{};
    uint64_t timer_seq = 0;
  };
  // Min-heap entry: the next moment peer `id` needs the I/O thread (send due or reply deadline).
  struct Timer {
    TimePoint due;
    PeerId id;
    uint64_t seq;
  };
  // One encoded telegram waiting for the batch send at the end of this turn of the loop.
  struct Outgoing {
    Peer* peer;
    size_t size;
    std::array<uint8_t, kMaxRequestSize> bytes;
  };
  static constexpr size_t kReceiveSlotSize = 512;  // LinUDP replies are <= 64 bytes

  Session(transport::UdpSocket socket, const Clock& clock, transport::ThreadScheduling scheduling);
  void Run();
  // Pops every timer due by `now`: time-outs and cyclic sends.
  void FireTimersLocked(TimePoint now);
  // Sends for the peers Expedite named (or on their reply while a request is outstanding).
  void TakeUrgentLocked(TimePoint now);
  // Time-out handling and, when due, the next telegram of `p`; then re-arms its timer.
  void ServicePeerLocked(Peer& p, TimePoint now);
  // Builds and encodes p's next telegram into the send batch (A-07: p must be idle).
  void QueueSendLocked(Peer& p, TimePoint now);
  // Hands the batch to the socket (sendmmsg) and counts refused telegrams.
  void FlushLocked();
  // Keeps exactly one live timer for `p` at its next due moment.
  void ArmLocked(Peer& p, TimePoint now);
  void HandleDatagramLocked(const transport::DatagramSlot& d, TimePoint now);
  void SetLinkLocked(Peer& p, LinkState to);
  // Closes the cycle periods of `p` that ended by `now` (ExchangeCounters::cycles/late_cycles,
  // late_cycles_stalled against the last I/O stall).
  void RollPeriodsLocked(Peer& p, TimePoint now);
  // Counts a stall of the I/O thread over [from, until] (decision 1312).
  void NoteStallLocked(TimePoint from, TimePoint until);

  const Clock& clock_;
  transport::UdpSocket socket_;
  const transport::Endpoint local_;
  const transport::ThreadScheduling scheduling_;
  const TimePoint epoch_;  // grid origin: every peer's periods start on a kGridTick boundary
  mutable std::mutex mu_;  // registrations, peer state, counters; held during peer callbacks
  bool stopping_ = false;
  PeerId next_id_ = 1;
  std::map<PeerId, Peer> peers_;  // node-based: Peer addresses stay valid until erased
  std::unordered_map<transport::Endpoint, Peer*> by_remote_;
  std::vector<Timer> timers_;  // min-heap on due, guarded by mu_
  SessionCounters counters_;
  // The last stall of the I/O thread (guarded by mu_): from the moment it should have woken to
  // the moment it did. Empty (from == until) before the first.
  TimePoint stall_from_{};
  TimePoint stall_until_{};
  // I/O thread buffers, reused every turn (guarded by mu_; the cycle allocates nothing).
  std::vector<Outgoing> outgoing_;
  std::vector<transport::OutgoingDatagram> outgoing_views_;
  std::vector<size_t> send_failed_;
  std::vector<std::array<uint8_t, kReceiveSlotSize>> receive_buffers_;
  std::vector<transport::DatagramSlot> receive_slots_;
  std::vector<PeerId> urgent_taken_;
  // Expedite's queue: a leaf lock, never held while calling a peer (lock order mu_ -> urgent_mu_).
  std::mutex urgent_mu_;
  std::vector<PeerId> urgent_;  // guarded by urgent_mu_
  std::mutex stop_mu_;          // serialises Stop() callers around the join
  std::thread thread_;
};

// Process-wide registry handing out one Session per local endpoint, so that every drive
// configured with the same bind_host:master_port shares one socket. A Session lives as
// long as a drive holds it. Port 0 never shares: each call opens a fresh ephemeral socket.
class SessionPool {
 public:
  static SessionPool& Instance();
  // The live session bound to `local`, or a newly opened one (bind and scheduling errors name
  // the address). FailedPrecondition when the live session runs its I/O thread with another
  // `scheduling`: every drive sharing bind_host:master_port must ask for the same one.
  absl::StatusOr<std::shared_ptr<Session>> Acquire(
      const transport::Endpoint& local, const Clock& clock,
      const transport::ThreadScheduling& scheduling = {});

 private:
  std::mutex mu_;
  std::unordered_map<transport::Endpoint, std::weak_ptr<Session>> sessions_;
};

}  // namespace drivegw::linmot::linudp
