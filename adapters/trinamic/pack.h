// Pack: the gateway's side of one SIXpack/QUADpack controller, shared by the axis drives of that
// controller. Owns the serialised ControllerSession and one poll thread that reads position/action
// ($20) and velocity ($21) of every registered axis and probes $43 for resets; re-applies every
// axis's parameter shadow after a detected reset before any other word goes out (CT-57, G-24).
// Reference: trinamic-sixpack.md §2.5, §4.2 $20/$21/$43, §8 CT-57; decisions 1081-1099.
#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive_config.h"
#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/session.h"

namespace drivegw::trinamic {

// One poll result of an axis: `$20` (posact, action, stop flag) plus the newest `$21` vact.
struct AxisSample {
  int32_t posact = 0;
  uint8_t action = 0;
  bool stop_flag = false;  // `$20` P6 bit 0, cleared by the PACK on read (L663): latch it
  int vact = 0;            // velocity register of the newest `$21` (−511..511)
  // When the `$20` query was handed to the session: a sample reflects every word that completed
  // before this instant (the session never interleaves, L357).
  SessionClock::time_point sent{};
};

// The drive side of a registration. Called from the Pack's poll thread (or from a thread inside
// Pack::Send), never with a session lock held; implementations may call Pack::Send.
class PackListener {
 public:
  virtual ~PackListener() = default;
  virtual void OnSample(const AxisSample& sample) noexcept = 0;
  virtual void OnLink(LinkState state, const std::string& reason) noexcept = 0;
  // The controller's health changed (decision 1431); every axis reports the same.
  virtual void OnHealth(const HealthInfo& health) noexcept { (void)health; }
  // The PACK was reset and this axis's ApplyCommands were re-sent (CT-57).
  virtual void OnControllerReset() noexcept = 0;
  // A second controller answered with our address (decision 1055).
  virtual void OnDuplicateAddress(const std::string& detail) noexcept = 0;
  // The words that bring a freshly reset PACK to this axis's configuration; controller-scoped
  // words only when `controller` (sent once per PACK).
  virtual std::vector<Command> ApplyCommands(bool controller) const = 0;
  // A configuration word the Pack sent (any axis's API write, native pass-through, re-apply):
  // every axis absorbs it so controller-wide values and pair currents stay equal in all shadows
  // (decisions 1072, 1073, 1098). Called with the Pack's callback lock held.
  virtual void AbsorbWord(const Command& word) noexcept = 0;
  // Would `value` for parameter `id` (controller-scoped, e.g. `$12.clkdiv`) break this axis's
  // configuration? InvalidArgument naming the drive and the rule (CT-55, L497).
  virtual absl::Status CheckShared(uint32_t id, int64_t value, int baud) const = 0;
};

struct PackCounters {
  uint64_t polls = 0;           // `$20` queries answered
  uint64_t velocity_polls = 0;  // `$21` queries answered
  uint64_t poll_failures = 0;
  uint64_t reset_probes = 0;     // `$43` every ~500 ms
  uint64_t resets = 0;           // resets detected (reset flag / observer)
  uint64_t reapplied_words = 0;  // configuration words sent by the (re-)apply path
  uint64_t duplicates = 0;
};

class Pack final : private SessionObserver {
 public:
  // Key: serial device (or CAN bus spec) + address. Returns the live Pack of that controller or
  // opens a new one (transport opened, session created, no I/O yet). Same key with different
  // transport settings: InvalidArgument naming the field.
  // `owner` ("drive 'feeder-x'") is named by a shared serial line's refusals (decision 1471).
  static absl::StatusOr<std::shared_ptr<Pack>> Acquire(const TrinamicConfig& config,
                                                       const std::string& owner = "");
  // "serial:/dev/ttyUSB0#1" or "can:udp:239.74.163.2:43113#1".
  static std::string KeyOf(const TrinamicConfig& config);

  ~Pack() override;
  Pack(const Pack&) = delete;
  Pack& operator=(const Pack&) = delete;

  // Registers `listener` for motor `axis`, polled every `poll_period`; its ApplyCommands are sent
  // before its first sample. Starts the poll thread. AlreadyExists for a second drive on `axis`.
  absl::Status Register(uint8_t axis, PackListener* listener,
                        std::chrono::milliseconds poll_period);
  // Returns once no callback of `listener` runs any more; stops the thread with the last axis.
  void Unregister(uint8_t axis);

  // One word through the session (serialised). Runs a pending re-apply first, so no motion word
  // reaches a freshly reset PACK before its parameters (CT-57); a motion word also gets a fresh
  // `$43` first and is not sent (Aborted) when that `$43` reveals a reset.
  absl::StatusOr<std::optional<Reply>> Send(const Command& command, Deadline deadline);
  // The `$44` tunnel: `data` (1..8 bytes) as one CAN frame on TunnelTransmitCanId(address).
  absl::Status SendTunnel(const std::vector<uint8_t>& data);
  // `$43` now (connect, framing detection, reset flag); re-apply if it reported a reset.
  absl::Status Probe();
  // Validates a controller-scoped parameter value against every registered axis (decision 1098).
  absl::Status CheckShared(uint32_t id, int64_t value, int baud);
  // Polls `axis` at once (a drive waiting for a command's confirmation).
  void PollSoon(uint8_t axis);

  LinkState link_state() const { return session_->link_state(); }
  // The controller's UP/DEMOTED/DOWN (decision 1431), shared by its axes.
  HealthInfo health() const { return session_->health(); }
  std::string link_reason() const;
  // Newest sample of every registered axis (the Pack's knowledge of motor activity, CT-56).
  std::map<uint8_t, AxisSample> samples() const;
  SessionCounters session_counters() const { return session_->counters(); }
  // The controller's wire trace on behalf of drive `drive` (ControllerSession::SetWireTrace).
  void SetWireTrace(const std::string& drive, bool on) { session_->SetWireTrace(drive, on); }
  PackCounters counters() const;
  const std::string& key() const { return key_; }
  const TrinamicConfig& config() const { return config_; }
  std::string name() const { return session_->name(); }
  uint8_t address() const { return config_.address; }
  // The serial line rate now (follows `$40`, G-40); nullopt on CAN.
  std::optional<int> line_baud() const { return session_->baud(); }
  // CT-20: the CAN bit rate the jumpers JP1/JP2 select, from `$30` P4 bits 6/7 (1 = set, G-19;
  // §3.2 table), read once per connect on CAN links; nullopt before that and on serial links.
  std::optional<int> can_bit_rate() const;

 private:
  struct Axis {
    PackListener* listener = nullptr;
    std::chrono::milliseconds period{20};
    SessionClock::time_point next{};
    bool needs_apply = true;
    bool applied_once = false;  // a reset before the first apply is the power-up, no news
    bool velocity_turn = false;
    int vact = 0;
    std::optional<AxisSample> last;
  };
  struct Event {
    enum Kind { kLink, kDuplicate, kHealth } kind;
    LinkState state = LinkState::kUnknown;
    std::string text;
    HealthInfo health;  // kHealth
  };

  Pack(TrinamicConfig config, std::string key, std::shared_ptr<ControllerSession> session);
  void Run();
  void PollAxis(uint8_t axis);
  void ProbeReset();
  // Reads the jumper bits (`$30`) after a connect on CAN (CT-20).
  void ReadJumpers();
  // One word through the session: `$40` via ChangeBaud (G-40); a sent configuration word is
  // absorbed by every axis (decision 1098). Callers hold cb_mu_ across it (absorb order = wire
  // order).
  absl::StatusOr<std::optional<Reply>> TransactWord(const Command& command, Deadline deadline);
  // Sends pending (re-)apply words; notifies OnControllerReset after a reset. Needs cb_mu_.
  absl::Status EnsureApplied();
  void DispatchEvents();

  // SessionObserver (session I/O lock held: record and wake the thread only).
  void OnHealthChange(const HealthInfo& health) noexcept override;
  void OnLinkChange(LinkState state, const std::string& reason) noexcept override;
  void OnControllerReset(uint8_t address) noexcept override;
  void OnSessionEvent(SessionEvent event, const std::string& detail) noexcept override;

  const TrinamicConfig config_;
  const std::string key_;
  std::shared_ptr<ControllerSession> session_;
  int observer_id_ = 0;

  // Held while a listener callback runs and around the (re-)apply path; recursive because
  // callbacks may send words (Pack::Send → EnsureApplied) from the poll thread.
  std::recursive_mutex cb_mu_;

  mutable std::mutex mu_;  // below
  std::condition_variable cv_;
  std::map<uint8_t, Axis> axes_;
  bool stop_ = false;
  bool reset_pending_ = false;
  uint64_t reset_gen_ = 0;  // resets reported by the session
  bool poke_ = false;       // PollSoon
  std::vector<Event> events_;
  std::string link_reason_;
  SessionClock::time_point next_reset_probe_{};
  SessionClock::time_point last_motion_probe_{};  // `$43` before the newest motion command
  bool jumpers_pending_ = false;                  // CAN: `$30` due after a connect
  std::optional<int> can_bit_rate_;
  PackCounters counters_;
  std::thread thread_;
};

}  // namespace drivegw::trinamic
