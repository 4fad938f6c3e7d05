// LinMotUdpDrive: the Drive of a LinMot MC SW drive over LinUDP V2 — control word sequences,
// motion commands with the count handshake, RTC parameter access, unified status.
// Sources: linmot-mc.md §2.7, §4.3, §4.4, D-04/D-09/D-11/D-36/D-42; linmot-linudp.md §5, A-05,
// A-07..A-10; decisions docs/decisions/701..705.
#pragma once

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive_base.h"
#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/linudp/curve_info_block.h"
#include "adapters/linmot/linudp/mc_count_guard.h"
#include "adapters/linmot/linudp/session.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/linmot/mc/state_var.h"
#include "adapters/linmot/mc/status_word.h"

namespace drivegw::linmot::linudp {

// Unified state of a LinMot main state (docs/decisions/701-linmot-state-mapping.md). Pure, for
// tests and other LinMot transports: `online` false gives OFFLINE.
DriveState MapLinMotState(bool online, mc::StateVar state_var, mc::StatusWord status_word);

// Planned duration of a VAI move over `distance_mm` starting at speed `v0_mm_s` (any sign, as
// magnitude towards the target is unknown it is treated as a possible reversal), linmot-mc.md
// §6.1 (D-21) trapezoid/triangle; the basis of the D-11 completion time-out.
Duration PlannedVaiDuration(double distance_mm, double v0_mm_s, double vmax_mm_s, double acc_mm_s2,
                            double dec_mm_s2);

class CurveService;

// Fault code of the gateway-side fault "stale motion command re-executed (network reordering)"
// (decision 1461): above the 16-bit range of LinMot error codes, so never a drive's own code.
inline constexpr uint32_t kFaultStaleMotionCommand = 0x10001;

class LinMotUdpDrive final : public DriveBase, private SessionPeer {
 public:
  // `config.linudp` must be set (CreateLinMotUdpDrive checks it); `clock` must advance in real
  // time and outlive the drive.
  LinMotUdpDrive(DriveConfig config, const Clock& clock);
  ~LinMotUdpDrive() override;

  std::string endpoint() const override;  // "udp://192.168.1.17:49360"

  absl::StatusOr<CommandInfo> Enable() override;
  absl::StatusOr<CommandInfo> Disable() override;
  absl::StatusOr<CommandInfo> Home() override;
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override;
  // Native asynchronous move (decision 1301): the count handshake of Move, started on the
  // caller's thread (the telegram leaves from there when the line is free, Session::SendUrgentNow)
  // and completed on `blocking` from the I/O thread's reply, time-out or link loss, or from
  // deactivation. While another operation runs it falls back to Move on `blocking`.
  void MoveAsync(const MotionCommand& cmd, Executor& blocking, CommandCompletion done) override;
  absl::StatusOr<CommandInfo> AcknowledgeFault() override;

  // Curves (issue 6; docs/decisions/707-linudp-curve-download-run.md, drive_curves.cpp): the
  // curve service with read-back (curve_service.h), and RunCurve as 044h with the curve's
  // offset/time/amplitude scale, downloaded first unless this session verified that very curve.
  absl::Status DownloadCurve(const LinMotParametricCurve& curve) override;
  absl::StatusOr<LinMotParametricCurve> UploadCurve(int curve_id) override;
  absl::StatusOr<CommandInfo> RunCurve(const Curve& curve, const CurveRunOptions& options) override;

  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override;
  absl::Status WriteParameter(const ParameterRef& ref, int64_t value) override;
  // LinMotMcRequest: header + parameter bytes checked against the mc catalogue, sent with the
  // count handshake like Move; the reply's command_id is the handle id, word2 = state var,
  // word3 = status word, word4 = warn word at acceptance. LinMotRtcRequest: one RTC transaction
  // status and words 2-4 as the drive answered, OK even for status >= 0xC0.
  // Restart Drive (0x30) follows A-11 and returns once the drive answers again after booting.
  absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) override;
  // Telegram hex of both directions, logged by the session (PeerOptions::wire_trace).
  absl::Status SetWireTrace(bool on) override {
    wire_trace_->store(on);
    return absl::OkStatus();
  }

  // Diagnostics for the dashboard; nullopt while not ACTIVE.
  std::optional<ExchangeCounters> exchange_counters() const;
  // missed = requests without a valid reply (timeouts), as drivegw_drive_wire_errors_total.
  LinkHealth link_health() const override {
    const auto c = exchange_counters();
    if (!c) return {};
    return {c->telegrams_sent, c->replies, c->timeouts, c->last_round_trip_ms};
  }
  std::optional<SessionCounters> session_counters() const;
  // Stale motion commands the drive executed (decision 1461), since construction; counted with
  // the wire errors (drivegw_drive_wire_errors_total{kind="stale_motion"}).
  uint64_t stale_motion_commands() const;
  std::optional<transport::Endpoint> local_endpoint() const;

 protected:
  absl::Status DoActivate() override;
  void DoDeactivate() override;

 private:
  // The newest reply, decoded (linmot-linudp.md §4.2).
  struct Sample {
    bool valid = false;
    mc::StateVar state_var;
    mc::StatusWord status_word;
    uint16_t warn_word = 0;
    uint16_t error_code = 0;
    int32_t actual_position = 0;  // 0.1 µm
    int32_t demand_position = 0;  // 0.1 µm
    std::optional<RtcReply> rtc;
    TimePoint received{};
  };
  struct PositionSample {
    TimePoint t;
    int32_t actual;
    int32_t demand;
  };
  // What a RunCurve handle needs besides the motion (decision 707).
  struct CurveTrack {
    uint16_t curve_id = 0;
    double end_mm = 0;        // D-29 end point of the run
    double tolerance_mm = 0;  // DONE needs |actual - end| <= this
    Duration duration{};      // curve time: progress = elapsed / duration
    std::optional<TimePoint> started;
    double reported = -1;  // progress last published
  };
  // FIFO of position samples on a ring that only grows (to the velocity window's sample count):
  // std::deque allocated a new block every few dozen replies (issue 10, P2: nothing allocated
  // per telegram).
  class SampleRing {
   public:
    void push_back(const PositionSample& s) {
      if (size_ == ring_.size()) Grow();
      ring_[(head_ + size_) % ring_.size()] = s;
      ++size_;
    }
    void pop_front() {
      head_ = (head_ + 1) % ring_.size();
      --size_;
    }
    const PositionSample& operator[](size_t i) const { return ring_[(head_ + i) % ring_.size()]; }
    const PositionSample& front() const { return (*this)[0]; }
    size_t size() const { return size_; }
    void clear() { head_ = size_ = 0; }

   private:
    void Grow() {
      std::vector<PositionSample> bigger(std::max<size_t>(8, 2 * ring_.size()));
      for (size_t i = 0; i < size_; ++i) bigger[i] = (*this)[i];
      ring_.swap(bigger);
      head_ = 0;
    }
    std::vector<PositionSample> ring_;
    size_t head_ = 0;
    size_t size_ = 0;
  };
  // A motion command between Move/SendNative and its final state (linmot-mc.md §4.4).
  struct MotionTracker {
    uint64_t id = 0;
    std::string kind;
    uint8_t count = 0;
    bool needs_in_target = true;  // motions: DONE needs In Target Position; Stop/native: no
    bool accepted = false;
    TimePoint accept_deadline{};
    std::optional<Duration> planned;  // nullopt: no completion time-out (native commands)
    std::optional<TimePoint> completion_deadline;
    std::optional<CurveTrack> curve;  // RunCurve only
  };
  enum class HomingPhase { kStarting, kRunning, kReleasing };
  struct HomingTracker {
    uint64_t id = 0;
    HomingPhase phase = HomingPhase::kStarting;
    TimePoint deadline{};
  };
  // What a blocking sequence step waits for.
  enum class Wait { kReached, kDeadline, kOffline, kInactive };

  // SessionPeer (I/O thread, under the session lock).
  Request BuildRequest() noexcept override;
  bool HasUrgentRequest() noexcept override;
  void OnReply(const Reply& reply, TimePoint received) noexcept override;
  void OnTimeout() noexcept override;
  void OnLinkChange(LinkState state) noexcept override;
  void OnHealthChange(const HealthInfo& health) noexcept override { SetHealth(health); }

  // All *Locked members need mu_.
  void EvaluateTrackersLocked(TimePoint now);
  void EvaluateMotionLocked(TimePoint now);
  void EvaluateHomingLocked(TimePoint now);
  void PublishLocked(bool force);
  DriveStatus BuildStatusLocked() const;
  // Flags a changed outbound state and wakes the session so it leaves at once (decision 006).
  void MarkUrgentLocked();
  void SetControlWordLocked(uint16_t cw);
  // Replaces an unaccepted MC block of `count` by No Operation with the same count.
  void DisarmMcBlockLocked(uint8_t count);
  // Decision 1461 on a reply in state 8: omits the MC block once its count is echoed, and halts
  // (/Abort) and latches FAULT when the echo shows a stale telegram was executed.
  void CheckCountEchoLocked();
  // The FAULT-latching reaction of CheckCountEchoLocked; `from` is the count that was current.
  void OnStaleMotionLocked(uint8_t from, uint8_t echo);
  bool OnlineLocked() const { return link_ == LinkState::kOnline && sample_.valid; }
  uint8_t MainStateLocked() const { return sample_.state_var.main_state; }
  std::string StateTextLocked() const;  // "main state 6 (Ready To Operate)"
  Fault FaultLocked() const;
  // Waits on cv_ until `reached()` (evaluated after each reply), the deadline, link loss (once
  // the link was up) or deactivation.
  template <typename Pred>
  Wait WaitLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline, Pred reached,
                  bool tolerate_offline = false);
  // Waits until a reply answered a telegram carrying the current control word.
  Wait WaitControlWordLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline);
  absl::Status WaitOnlineLocked(std::unique_lock<std::mutex>& lock, TimePoint deadline,
                                const char* operation);
  absl::Status WaitFailure(Wait w, const char* operation, const std::string& detail) const;

  // Ends command `id` with `status` mapped to ERROR (or DONE when ok) and returns the result
  // the API call hands back.
  absl::StatusOr<CommandInfo> Finish(uint64_t id, const absl::Status& status);

  // An asynchronous move waiting for its count echo (MoveAsync); it holds the operation like
  // op_mu_ does for a blocking one, so LockOperation waits for it.
  struct AsyncAccept {
    uint64_t id = 0;
    std::string kind;
    uint8_t count = 0;
    TimePoint deadline{};
    Executor* executor = nullptr;
    CommandCompletion done;
  };
  // op_mu_ once no asynchronous move is pending: every blocking operation starts with this.
  std::unique_lock<std::mutex> LockOperation();
  // Move's checks and encoding (online, limits, units) with the drive's name in the message.
  absl::StatusOr<mc::McCommand> BuildMoveLocked(const MotionCommand& cmd, bool& needs_in_target,
                                                Duration& planned);
  // Checks state 8, creates the handle and arms the MC block (wake: Expedite the session now;
  // else the caller sends after releasing mu_).
  absl::StatusOr<MotionTracker> StartMotionLocked(const std::string& kind, const mc::McCommand& cmd,
                                                  bool needs_in_target,
                                                  std::optional<Duration> planned,
                                                  std::optional<CurveTrack> curve, bool wake);
  // True once command `id` was accepted or ended (what the count handshake waits for).
  bool AcceptSettledLocked(uint64_t id) const;
  // The handshake's result for `id` after a wait that ended with `w` (cleans up a failed one).
  absl::StatusOr<CommandInfo> AcceptResultLocked(Wait w, uint64_t id, const std::string& kind,
                                                 uint8_t count);
  // Completes a pending MoveAsync once its handshake settled (called after every reply,
  // time-out, link change and on deactivation); posts the completion to its executor.
  void ResolveAsyncAcceptLocked(TimePoint now);

  // Move/SendNative common path: checks state 8, creates the handle, runs the count handshake.
  absl::StatusOr<CommandInfo> RunMotion(const std::string& kind, const mc::McCommand& cmd,
                                        bool needs_in_target, std::optional<Duration> planned,
                                        std::optional<CurveTrack> curve = std::nullopt);
  // RunCurve's progress and end-point check on a reply (drive_curves.cpp). Returns the final
  // state and message when the curve run ends now, else nullopt.
  std::optional<std::pair<CommandState, std::string>> EvaluateCurveLocked(MotionTracker& m,
                                                                          TimePoint now,
                                                                          bool finished);
  // Runs `fn` with the curve service while holding the RTC channel (one sequence at a time).
  absl::Status WithCurveService(const std::function<absl::Status(CurveService&)>& fn);
  // Downloads and verifies `wire` unless this session verified exactly it; fills the cache.
  absl::Status EnsureCurve(const WireCurve& wire, bool force);
  absl::StatusOr<mc::McCommand> BuildMotion(const MotionCommand& cmd, bool& needs_in_target,
                                            Duration& planned);
  // One RTC transaction; returns the final reply (status may be >= 0xC0).
  absl::StatusOr<RtcReply> RtcTransact(uint8_t command_id, uint16_t word2, uint16_t word3,
                                       uint16_t word4, Duration timeout, const std::string& what);
  absl::StatusOr<RtcReply> RtcTransactLocked(std::unique_lock<std::mutex>& lock, uint8_t command_id,
                                             uint16_t word2, uint16_t word3, uint16_t word4,
                                             TimePoint deadline, Duration timeout,
                                             const std::string& what);
  // Restart Drive 0x30 with the A-11 handshake: count 0, silence, first reply with echo 0.
  absl::StatusOr<RtcReply> RtcRestart(Duration timeout);

  const Clock& clock_;
  const std::string name_;
  // "udp://host:port", formatted once: host and port are the const config's (decision 1363).
  const std::string endpoint_;
  const std::shared_ptr<std::atomic<bool>> wire_trace_ = std::make_shared<std::atomic<bool>>(false);

  std::mutex op_mu_;   // one control-word / motion operation at a time
  std::mutex rtc_mu_;  // one RTC transaction at a time

  mutable std::mutex mu_;  // below; lock order: session lock -> mu_ -> DriveBase's lock
  std::condition_variable cv_;
  bool active_ = false;
  std::shared_ptr<Session> session_;
  PeerId peer_id_ = 0;
  LinkState link_ = LinkState::kUnknown;
  Sample sample_;
  SampleRing history_;               // velocity window
  double velocity_mm_s_ = 0;         // from actual positions (decision 703)
  double demand_velocity_mm_s_ = 0;  // from demand positions, for planning
  uint64_t replies_ = 0;
  uint64_t timeouts_ = 0;

  // Outbound state: what every telegram carries (linmot-linudp.md §3).
  std::optional<uint16_t> control_word_;  // unset: no control word block (linudp §6.8)
  uint64_t cw_generation_ = 0;
  bool urgent_ = false;        // outbound state changed since the last telegram (decision 006)
  uint64_t cw_in_flight_ = 0;  // generation carried by the outstanding telegram
  uint64_t cw_answered_ = 0;   // generation carried by the telegram the newest reply answered
  // Sent only until its count is echoed (decision 1461): a telegram built after the echo can
  // never re-execute the command, whenever the network delivers it.
  std::optional<mc::McBlock> mc_block_;
  McCountGuard mc_guard_;
  // Set when a stale telegram was executed (decision 1461): FAULT until AcknowledgeFault, which
  // releases the /Abort halt; motion commands and Enable are refused meanwhile.
  std::optional<std::string> stale_fault_;
  uint64_t stale_motion_commands_ = 0;
  std::optional<RtcRequest> rtc_block_;
  uint64_t rtc_generation_ = 0;
  uint64_t rtc_in_flight_ = 0;
  uint64_t rtc_answered_ = 0;

  std::optional<MotionTracker> motion_;
  std::optional<AsyncAccept> async_accept_;
  uint64_t accepted_id_ = 0;  // newest motion command the drive accepted (count echo seen)
  std::optional<HomingTracker> homing_;

  // Curves this session downloaded and read back (decision 707); cleared when the link drops
  // (a reboot is silent) and by native RTC commands that change curves.
  std::map<uint16_t, WireCurve> verified_curves_;
  uint64_t curve_epoch_ = 0;

  std::optional<DriveStatus> published_;
  TimePoint published_at_{};
  // Everything BuildStatusLocked reads, as of the last BuildStatusLocked in PublishLocked: an
  // unchanged reply then skips building (and allocating) a status that SameStatus would drop
  // anyway (issue 10, P2: nothing allocated per telegram while a drive stands still).
  struct StatusInputs {
    bool online = false;
    bool valid = false;
    uint16_t state_var = 0;
    uint16_t status_word = 0;
    uint16_t warn_word = 0;
    uint16_t error_code = 0;
    int32_t actual_position = 0;
    int32_t demand_position = 0;
    double velocity_mm_s = 0;
    bool stale_fault = false;
    friend bool operator==(const StatusInputs&, const StatusInputs&) = default;
  };
  StatusInputs StatusInputsLocked() const;
  std::optional<StatusInputs> published_inputs_;
};

}  // namespace drivegw::linmot::linudp
