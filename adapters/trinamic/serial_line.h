// SerialLine: one serial device shared by every controller session on it. An RS-485 line carries
// up to 255 PACKs, each with its own unit address (trinamic-sixpack.md §2.1/§2.2, L273, L275);
// the line is opened and set up (termios) once, and one request/reply transaction at a time runs
// on it: "no interlacing" (L357) and an idle bus while a reply is due (L742) hold for the line,
// not per PACK. Decision 1471.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/serial_port.h"

namespace drivegw::trinamic {

// A controller on a line: its unit address A, the RA of its queries (§2.4) and who configured it
// ("drive 'feeder-x'"; empty = "address N") for refusals.
struct LineMember {
  uint8_t address = 1;
  uint8_t response_address = 0xF0;
  std::string owner;
};
std::string DescribeMember(const LineMember& member);

class SerialLine {
 public:
  using Clock = std::chrono::steady_clock;

  // The live line of `config.device` (symlinks resolved, so a by-id path and its tty are one
  // line) with `member` added, or a line opened now. InvalidArgument naming the line and both
  // controllers when the settings differ from the line's (baud, duplex, turnaround), when the
  // address is already on the line, or when an RA equals another member's address (§2.4, CT-50).
  // The port's open error otherwise.
  static absl::StatusOr<std::shared_ptr<SerialLine>> Attach(const transport::SerialConfig& config,
                                                            const LineMember& member);
  ~SerialLine();
  SerialLine(const SerialLine&) = delete;
  SerialLine& operator=(const SerialLine&) = delete;

  // Removes `address` (its session closes); the line closes with its last member.
  void Detach(uint8_t address);

  // Held for one transaction (request, reply, after-reply window) or a baud switch.
  std::unique_lock<std::mutex> Lock() { return std::unique_lock<std::mutex>(line_mu_); }

  // ---- under Lock() ----
  // Opens the port again after a transport failure closed it (no-op when open).
  absl::Status Open();
  void Close();
  transport::SerialPort* port() { return port_ ? &*port_ : nullptr; }
  // End of the newest word or reply on the line, by any member (§2.5 command gap, L303).
  Clock::time_point last_word_end() const { return last_word_end_; }
  void set_last_word_end(Clock::time_point t) { last_word_end_ = t; }
  // Reconfigures the port rate; refused (FailedPrecondition naming them) while other members
  // are on the line: a `$40` reaches one PACK, the others would stay at the old rate (G-40).
  absl::Status SetBaud(int baud, uint8_t requester);
  int baud() const { return config_.baud; }
  // SetBaud's refusal without the change (checked before a `$40` goes out).
  absl::Status CheckRateChange(int baud, uint8_t requester) const;

  // ---- any thread ----
  const std::string& device() const { return config_.device; }
  // The member other than `self` whose queries carry response address `ra` (R9 replies start
  // with it, §2.4), if any.
  std::optional<LineMember> MemberWithResponseAddress(uint8_t ra, uint8_t self) const;
  // The members other than `self`, described ("drive 'b' (address 2)"), empty when alone.
  std::vector<std::string> Neighbours(uint8_t self) const;

 private:
  SerialLine(std::string key, transport::SerialConfig config, transport::SerialPort port);
  absl::Status Admit(const transport::SerialConfig& config, const LineMember& member) const;

  const std::string key_;  // resolved device path (registry key)
  transport::SerialConfig config_;
  const transport::SerialConfig configured_;  // as attached, compared with later members

  std::mutex line_mu_;
  std::optional<transport::SerialPort> port_;  // under line_mu_
  Clock::time_point last_word_end_{};          // under line_mu_

  mutable std::mutex members_mu_;
  std::vector<LineMember> members_;
};

}  // namespace drivegw::trinamic
