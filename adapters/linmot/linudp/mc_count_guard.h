// The MC count bookkeeping that keeps a reordered (stale) telegram from re-running a motion
// command (decision 1461, finding 1424). The MC interface executes a block whenever its count
// nibble differs from the last one interpreted (linmot-mc.md §4.3 rule 1), so a telegram that the
// network delivers after a newer one re-executes the older command. The drive therefore sends
// the MC block only until its count is echoed (Omit), and this guard recognises the case left
// over: the echo going back to a count superseded earlier (Stale). Pure logic, no I/O.
#pragma once

#include <cstdint>
#include <optional>

namespace drivegw::linmot::linudp {

class McCountGuard {
 public:
  enum class Verdict {
    kNone,  // nothing to do
    kEcho,  // the current count is echoed: the drive interpreted it, the block may be omitted
    kStale  // the echo went back to a superseded count: a stale telegram was executed
  };

  // A new MC block with `count` replaces the current one (a No Operation that disarms an
  // unaccepted command keeps the count and is no new block). `drive_echo` is the count the drive
  // shows now (nullopt: not known, e.g. not in state 8): until the new count is echoed, that one
  // is expected, every other superseded count is stale.
  void Arm(uint8_t count, std::optional<uint8_t> drive_echo);
  // A reply in main state 8 shows `echo` (state var bits 3-0, linmot-mc.md §2.1). kStale when
  // the echo is one of our superseded counts other than the one the drive showed when the
  // current block was armed (and, once the current count was echoed, any superseded count).
  // Echo 0 is never stale: it is the count after a reboot (§4.3 rule 4) and never one of ours
  // . After kStale the guard adopts `echo` as the drive's count (and the current count as
  // superseded), so a second stale telegram is recognised again.
  Verdict OnEcho(uint8_t echo);
  // A new activation: the drive may have been commanded by anyone meanwhile.
  void Reset() { *this = McCountGuard{}; }

  std::optional<uint8_t> current() const { return current_; }
  bool echoed() const { return echoed_; }

 private:
  static uint16_t Bit(uint8_t count) { return static_cast<uint16_t>(1u << (count & 0x0F)); }

  std::optional<uint8_t> current_;  // count of the newest block put on the wire
  bool echoed_ = false;             // a reply in state 8 showed current_
  std::optional<uint8_t> base_;     // the drive's count when current_ was armed
  uint16_t superseded_ = 0;         // bit c: count c was sent, then replaced by a newer count
};

}  // namespace drivegw::linmot::linudp
