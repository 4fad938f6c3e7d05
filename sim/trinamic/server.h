// TrinamicServer: simulated SIXpack/QUADpacks on a pseudo-terminal (one unit, or several on one
// RS-485 line); the controllers are advanced to an injected clock on every byte burst (never by
// sleeping), with packet timeout, break, switchover delay, baud check and faults.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/transport/impaired_link.h"
#include "adapters/transport/pty.h"
#include "sim/trinamic/controller.h"
#include "sim/trinamic/options.h"
#include "sim/trinamic/word_assembler.h"

namespace drivegw::sim::trinamic {

struct ServerCounters {
  uint64_t bytes_in = 0;
  uint64_t words = 0;             // complete 9-byte words decoded
  uint64_t words_dropped = 0;     // complete words the codec refused (unknown opcode, G-06)
  uint64_t partial_timeouts = 0;  // partial words discarded by the packet timeout (L279)
  uint64_t replies = 0;
  uint64_t resets = 0;       // injected power losses
  uint64_t breaks = 0;       // breaks that discarded a partial word (L279)
  uint64_t noise_bytes = 0;  // bytes ignored at the wrong peer speed (check_peer_baud)
  uint64_t reset_bytes = 0;  // stray `00` bytes sent after `$CC` (L228, L902)
  // SetImpairment (decision 1421): host words and replies dropped, duplicated, held back one
  // (reordered) or corrupted (a host word with a bit flipped fails its checksum, so it is lost
  // like a dropped one; a reply goes out with one bit flipped).
  uint64_t words_impaired_dropped = 0;
  uint64_t words_impaired_duplicated = 0;
  uint64_t words_impaired_reordered = 0;
  uint64_t words_impaired_corrupted = 0;
  uint64_t replies_impaired_dropped = 0;
  uint64_t replies_impaired_duplicated = 0;
  uint64_t replies_impaired_reordered = 0;
  uint64_t replies_impaired_corrupted = 0;
};

// Thread model: one thread owns the pty loop; public methods are thread-safe and serialised with
// it by one mutex. Counters of word framing are those of the first unit. Replies are written at
// once, or with `turnaround` held until the `$40` switchover time has passed on the injected
// clock (decisions 1037, 1040).
class TrinamicServer {
 public:
  // `clock` must outlive the server (ManualClock in tests, SteadyClock::Instance() otherwise).
  static absl::StatusOr<std::unique_ptr<TrinamicServer>> Start(const ServerOptions& options,
                                                               const Clock& clock);
  ~TrinamicServer();
  TrinamicServer(const TrinamicServer&) = delete;
  TrinamicServer& operator=(const TrinamicServer&) = delete;

  const std::string& slave_path() const { return pty_.slave_path(); }
  void Stop();  // idempotent
  ServerCounters counters() const;

  // ---- fault injection and introspection (take effect at clock.Now()) ----
  void SetSilent(bool silent);
  // Unit `index` alone (0 = options.controller, then options.more_units) executes words but never
  // answers: a dead PACK among live ones on one RS-485 line (decision 1471).
  void SetUnitSilent(size_t index, bool silent);
  // Seeded faults on the serial line (decision 1421): `host_words` applies to every complete
  // word from the host before the units execute it, `replies` to every reply. Only drop and
  // corrupt: a UART line neither duplicates nor reorders, delays are the PACK's turnaround.
  // InvalidArgument naming the field; FailedPrecondition with more than one unit on the line.
  absl::Status SetImpairment(const transport::Impairment& host_words,
                             const transport::Impairment& replies);
  void LoseSteps(int motor, int64_t steps);
  void SetStuckSwitch(int motor, std::optional<bool> level);
  // Runs `fn` on the controller under the lock after advancing it to clock.Now().
  void WithController(const std::function<void(Controller&)>& fn);
  // The same for unit `index` (0 = options.controller, then options.more_units in order).
  void WithUnit(size_t index, const std::function<void(Controller&)>& fn);
  size_t unit_count() const { return units_.size(); }
  // Out-of-band break received at clock.Now(): every unit discards its partial word (L279). A pty
  // carries no break (§2.7, G-39), so tests and tools call this instead of tcsendbreak.
  void Break();
  // Wire trace (tests, CT-01/CT-02): every word a unit executed, re-encoded as its 9 bytes, oldest
  // first (bounded); ClearWords empties it.
  std::vector<std::vector<uint8_t>> words() const;
  void ClearWords();
  // Both directions in line order (tests, CT-10 "no interlacing"): every word unit 0 executed
  // (from_host) and every byte burst the server wrote (replies, stray `00`), bounded like words();
  // ClearWords empties it too.
  struct WireEvent {
    bool from_host = false;
    std::vector<uint8_t> bytes;
  };
  std::vector<WireEvent> wire() const;

 private:
  struct Unit {
    Controller controller;
    WordAssembler words;
    uint64_t resets_seen = 0;
    bool silent = false;  // SetUnitSilent
  };
  struct PendingReply {
    TimePoint due;
    std::vector<uint8_t> bytes;
  };

  TrinamicServer(const ServerOptions& options, const Clock& clock, transport::PseudoTerminal pty,
                 std::vector<Unit> units);
  void Run();
  void AdvanceLocked();
  void AdvanceUnitLocked(Unit& unit, TimePoint now);
  void ReceiveLocked(const std::vector<uint8_t>& bytes);
  // Applies the host-word impairment (one unit on the line), then HandleLocked.
  void ImpairWordLocked(Unit& unit, const drivegw::trinamic::Command& command, TimePoint now);
  void HandleLocked(Unit& unit, const drivegw::trinamic::Command& command, TimePoint now);
  void ReplyLocked(const Unit& unit, std::vector<uint8_t> bytes, TimePoint at);  // impaired
  void ReplyNowLocked(const Unit& unit, std::vector<uint8_t> bytes, TimePoint at);
  void FlushLocked(TimePoint now);
  void SendLocked(const std::vector<uint8_t>& bytes);

  ServerOptions options_;
  const Clock& clock_;
  transport::PseudoTerminal pty_;
  mutable std::mutex mu_;
  std::vector<Unit> units_;  // [0] = options.controller
  std::deque<PendingReply> outbox_;
  TimePoint start_;
  TimePoint advanced_to_;
  bool reset_done_ = false;
  ServerCounters counters_;
  std::optional<transport::ImpairedLink> word_impairment_;
  std::optional<transport::ImpairedLink> reply_impairment_;
  std::optional<drivegw::trinamic::Command> held_word_;
  std::optional<std::vector<uint8_t>> held_reply_;
  std::deque<std::vector<uint8_t>> trace_;
  std::deque<WireEvent> wire_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivegw::sim::trinamic
