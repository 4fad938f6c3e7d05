// Trinamic controller session: the serialised request/reply layer of one PACK over serial or CAN.
// Reference: shared/protocols/trinamic-sixpack.md §2.3-2.6 (serial), §3.1/§3.4 (CAN), §4.2 $43;
// decisions docs/decisions/1051-1056.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/drive_config.h"
#include "adapters/core/health.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/serial_port.h"
#include "adapters/trinamic/codec.h"

namespace drivegw::trinamic {

using SessionClock = std::chrono::steady_clock;
using Deadline = SessionClock::time_point;

struct SessionOptions {
  uint8_t address = 1;              // unit address A of the controller (§2.2, 1..255, G-05)
  uint8_t response_address = 0xF0;  // RA of every query (§2.4 project default; 1052)
  int offline_after_misses = 3;     // consecutive missed/garbled replies → OFFLINE (1054)
  std::chrono::milliseconds probe_timeout{200};  // one $43 probe (framing detection, G-01)
  std::chrono::milliseconds retry_min{100};      // reconnect back-off, doubling ...
  std::chrono::milliseconds retry_max{5000};     // ... up to this
  // DEMOTED -> UP only after this long without a miss (health.up_after_ms, decision 1432).
  std::chrono::milliseconds up_after{kDefaultUpAfter};
  // §2.5 [P]: consecutive words at least 2 ms apart (L303).
  std::chrono::microseconds command_gap{2000};
  // After a reply the session listens this long for a second answer (duplicate address, 1055).
  std::chrono::microseconds duplicate_window{2000};
  std::chrono::milliseconds break_duration{10};  // resync break (§2.3, L279)
  // After a $CC hardware reset the PACK boots for ca. 1 s (L900, G-43): OFFLINE until then.
  std::chrono::milliseconds reset_boot_time{1000};
  // Serial only: the PACK's rate after any reset (19200, L273, L899). When a connection probe at
  // another rate fails, the session tries once at this rate (a reset PACK forgot its `$40`,
  // G-40) and stays there if it answers. nullopt: never.
  std::optional<int> reset_baud;
  // G-40: after switching its own port the session waits this long before the verifying `$43`.
  std::chrono::milliseconds baud_settle{10};
  // Who configured this controller ("drive 'feeder-x'"), named by the refusals of a shared
  // serial line (decision 1471); empty: "address N".
  std::string owner;
};

struct SessionCounters {
  uint64_t requests = 0;           // words sent (probes included)
  uint64_t replies = 0;            // valid replies matched to their query
  uint64_t timeouts = 0;           // queries without a (complete) reply
  uint64_t garbage = 0;            // wrong first byte, undecodable reply, wrong opcode/RA
  uint64_t resyncs = 0;            // Flush (+ break on serial) after garbage or a partial word
  uint64_t stray_zeros = 0;        // 00 bytes discarded (after a reset, L228/L902)
  uint64_t unsolicited = 0;        // bytes/frames pending before a request (late replies)
  uint64_t duplicate_replies = 0;  // a second answer to one query (same address twice, 1055)
  uint64_t resets_seen = 0;        // $43 replies with the reset flag set (L853)
  uint64_t probes = 0;             // $43 connection probes
  uint64_t probe_failures = 0;
  uint64_t offline_events = 0;
  uint64_t io_errors = 0;  // transport failures (link closed and reopened by the next probe)
  // Serial line shared with other controllers: replies carrying another member's RA (R9, §2.4),
  // i.e. a neighbour's late reply, dropped (decision 1471).
  uint64_t wrong_address = 0;
};

enum class LinkState { kUnknown, kOnline, kOffline };
const char* ToString(LinkState state);

enum class SessionEvent { kGarbage, kDuplicateAddress, kIoError };
const char* ToString(SessionEvent event);

// Observers are called on the thread running Transact while the session's I/O lock is held:
// they must be quick and must not call Transact/Probe synchronously (schedule it instead).
class SessionObserver {
 public:
  virtual ~SessionObserver() = default;
  // kOnline after a successful probe; kOffline after offline_after_misses misses or an I/O error.
  virtual void OnLinkChange(LinkState state, const std::string& reason) noexcept {
    (void)state;
    (void)reason;
  }
  // A $43 reply carried the reset flag (§4.2 $43 P1, L853): every parameter is back at its
  // default (G-24); the drive re-sends its parameter set.
  virtual void OnControllerReset(uint8_t address) noexcept { (void)address; }
  // The controller's HealthModel info changed (decision 1431).
  virtual void OnHealthChange(const HealthInfo& health) noexcept { (void)health; }
  virtual void OnSessionEvent(SessionEvent event, const std::string& detail) noexcept {
    (void)event;
    (void)detail;
  }
};

// The byte/frame side the session logic runs over (serial or CAN). Used under the session lock.
class SessionLink {
 public:
  virtual ~SessionLink() = default;
  virtual std::string Name() const = 0;
  // Held around each transaction: a link shared with other controllers (a serial line, decision
  // 1471) carries one request/reply at a time. Empty lock: nothing shared. The calls below run
  // under it.
  virtual std::unique_lock<std::mutex> LockLine() { return {}; }
  // End of the newest word on the link by any controller (§2.5 command gap); none: epoch.
  virtual SessionClock::time_point LineWordEnd() const { return {}; }
  virtual void SetLineWordEnd(SessionClock::time_point t) { (void)t; }
  // The other controllers on this link, described; empty when alone.
  virtual std::vector<std::string> Neighbours() const { return {}; }
  virtual absl::Status Open() = 0;  // no-op when already open
  virtual void Close() = 0;
  // Discards pending input before a request; returns how many bytes/frames were dropped and adds
  // discarded 00 bytes to `stray_zeros`.
  virtual size_t Drain(uint64_t& stray_zeros) = 0;
  virtual absl::Status Send(const Command& command) = 0;
  // The reply to `command`. DeadlineExceeded: nothing (complete) came; DataLoss: garbage (the
  // link already resynchronised); other codes: the transport failed. `detect` = framing probe.
  virtual absl::StatusOr<Reply> Receive(const Command& command, uint8_t response_address,
                                        Deadline deadline, bool detect,
                                        SessionCounters& counters) = 0;
  // After a reply: listens `window` for more input. kDuplicate: a second answer to the same query
  // (another controller with this address, decision 1055); kGarbage: other bytes (dropped, the
  // reply stands).
  enum class Extra { kNone, kDuplicate, kGarbage };
  virtual Extra AfterReply(std::chrono::microseconds window, SessionCounters& counters) = 0;
  virtual std::optional<ReplyFraming> framing() const { return std::nullopt; }
  // Serial links: the line rate now / reconfigure the port (G-40). CAN has no line rate.
  virtual std::optional<int> baud() const { return std::nullopt; }
  virtual absl::Status SetBaud(int baud) {
    (void)baud;
    return absl::FailedPreconditionError("baud rate needs a serial link");
  }
  // SetBaud's refusal before anything is sent (a rate change on a shared line, decision 1471).
  virtual absl::Status CheckBaudChange(int baud) const {
    (void)baud;
    return absl::OkStatus();
  }
  // One raw CAN frame (the `$44` RS-232 tunnel, §3.5 L307-317); serial links cannot.
  virtual absl::Status SendCanFrame(uint16_t id, const std::vector<uint8_t>& data) {
    (void)id;
    (void)data;
    return absl::FailedPreconditionError("tunnel needs CAN");
  }
};

class ControllerSession {
 public:
  // Serial (RS-232/RS-485 per config.duplex; SerialPort honours config.turnaround, §2.5). The
  // device is one SerialLine shared with every other session on it (decision 1471): refused
  // (InvalidArgument naming both owners) for other line settings or an address already on it.
  static absl::StatusOr<std::shared_ptr<ControllerSession>> OpenSerial(
      const transport::SerialConfig& config, const SessionOptions& options);
  // CAN: command ID = A << 3, reply ID = RA << 3 (§3.1). On a shared bus give every controller's
  // session its own response address (1053).
  static absl::StatusOr<std::shared_ptr<ControllerSession>> OpenCan(const CanBusConfig& bus,
                                                                    const SessionOptions& options);
  static absl::StatusOr<std::shared_ptr<ControllerSession>> OpenCan(
      std::unique_ptr<transport::CanChannel> channel, const SessionOptions& options);
  // Any link (tests, future transports).
  static absl::StatusOr<std::shared_ptr<ControllerSession>> Open(std::unique_ptr<SessionLink> link,
                                                                 const SessionOptions& options);

  ControllerSession(const ControllerSession&) = delete;
  ControllerSession& operator=(const ControllerSession&) = delete;

  // One request, never interleaved with another (L357). Queries return their reply, silent
  // commands nullopt. Not yet connected / OFFLINE with a probe due: a $43 probe runs first
  // (framing detection, G-01); OFFLINE before the back-off ends: Unavailable at once.
  // InvalidArgument for an invalid command or one for another address; DeadlineExceeded
  // "trinamic <link> address 1: query_position: no reply ..." on a time-out; Unavailable for
  // garbage (resynchronised), a failed transport or OFFLINE; FailedPrecondition when a second
  // controller answered (duplicate address).
  absl::StatusOr<std::optional<Reply>> Transact(const Command& command, Deadline deadline);
  // Runs the $43 probe now (connect, framing detection, reset flag).
  absl::Status Probe();
  // RS-232-over-CAN tunnel (§3.5, L307-317): `data` (1..8 bytes) as one frame on
  // TunnelTransmitCanId(address), DLC = size, serialised with Transact. Serial link:
  // FailedPrecondition "tunnel needs CAN"; InvalidArgument for 0 or more than 8 bytes.
  absl::Status SendTunnel(const std::vector<uint8_t>& data);
  // CT-08 / G-40, one step under the request lock: sends the `$40` word at the current rate,
  // switches the own port to 1 250 000 / divisor (standard rates only, BaudOfDivisor), waits
  // options.baud_settle and verifies with a `$43`. No `$43` answer: the port returns to the old
  // rate and Unavailable names both rates. A CAN link only sends the word (it sets the PACK's
  // RS-232 rate, not the bus). InvalidArgument for another opcode or a non-standard divisor.
  absl::Status ChangeBaud(const Command& set_baud_rate, Deadline deadline);
  // Reconfigures the own serial port only (no word sent); FailedPrecondition on CAN.
  absl::Status SetBaud(int baud);
  // The serial line rate now; nullopt on CAN.
  std::optional<int> baud() const;

  int AddObserver(SessionObserver* observer);
  void RemoveObserver(int id);

  LinkState link_state() const;
  // UP/DEMOTED/DOWN of the controller (decision 1431): DOWN exactly while OFFLINE.
  HealthInfo health() const;
  // The probe interval of an OFFLINE controller now (the shared model's back-off).
  std::chrono::milliseconds probe_backoff() const;
  std::optional<ReplyFraming> framing() const;
  SessionCounters counters() const;
  std::string name() const { return name_; }
  const SessionOptions& options() const { return options_; }

  // Wire trace of the drive `drive` on this controller (Drive::SetWireTrace): while any drive
  // has it on, every word of the line and its reply is logged as hex, naming those drives (the
  // axes share one serialised line, L357).
  void SetWireTrace(const std::string& drive, bool on);

 private:
  ControllerSession(std::unique_ptr<SessionLink> link, const SessionOptions& options);
  absl::Status ProbeLocked();
  // link_->LockLine(), `deadline` moved on by the time spent waiting for it.
  std::unique_lock<std::mutex> LockLine(Deadline& deadline);
  absl::StatusOr<std::optional<Reply>> TransactLocked(const Command& command, Deadline deadline);
  absl::Status SetBaudLocked(int baud);
  absl::StatusOr<Reply> Exchange(const Command& command, Deadline deadline, bool detect);
  void Miss(const std::string& reason);
  // Hands a changed health to the observers (under the I/O lock, like the other events).
  void PublishHealth();
  void SetState(LinkState state, const std::string& reason);
  void CheckReset(const Reply& reply);
  void Emit(SessionEvent event, const std::string& detail);
  std::string Where(const Command& command) const;

  const SessionOptions options_;
  std::unique_ptr<SessionLink> link_;
  const std::string name_;

  std::mutex io_mutex_;  // serialises requests (L357)
  Deadline last_word_end_{};
  // Miss counting, OFFLINE and the probe back-off (decision 1431); under io_mutex_.
  HealthModel health_;

  mutable std::mutex state_mutex_;
  LinkState state_ = LinkState::kUnknown;
  HealthInfo health_info_;  // health_.info() mirrored for health() without the I/O lock
  std::chrono::milliseconds backoff_mirror_{0};
  std::optional<int> baud_;  // the link's rate, mirrored for baud() without the I/O lock
  SessionCounters counters_;

  std::atomic<bool> tracing_{false};
  std::set<std::string> traced_drives_;  // under state_mutex_

  std::mutex observers_mutex_;
  std::map<int, SessionObserver*> observers_;
  int next_observer_id_ = 1;
};

}  // namespace drivegw::trinamic
