// RAII pseudo-terminal pair (openpty, raw): the simulator's serial endpoint and the tests' peer.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace drivegw::transport {

// Move-only; the destructor closes both descriptors and removes the symlink (only if it still
// points at this pty's slave). The slave descriptor stays open for the object's lifetime so that
// the master never reads EIO while no client has the slave open (a gateway reconnecting).
// Like SerialPort, one owner thread makes the calls (trinamic-sixpack.md §2.7 notes: a pty
// accepts any baud and enforces no character timing; break never reaches the master, G-39).
class PseudoTerminal {
 public:
  // openpty(), raw mode (cfmakeraw, CS8, CLOCAL|CREAD, VMIN=VTIME=0) on the shared termios, master
  // non-blocking. With `symlink_path`, a symlink to the slave is put there (`--pty PATH`); a
  // stale symlink is replaced, any other existing file is AlreadyExists. Errors name the path and
  // the errno text.
  static absl::StatusOr<PseudoTerminal> Open(const std::string& symlink_path = "");

  PseudoTerminal(PseudoTerminal&& other) noexcept;
  PseudoTerminal& operator=(PseudoTerminal&& other) noexcept;
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;
  ~PseudoTerminal();

  const std::string& slave_path() const { return slave_path_; }
  const std::string& symlink_path() const { return symlink_path_; }
  int master_fd() const { return master_fd_; }

  // The speed the slave side last set (both ends share one termios, §2.7), as a baud number;
  // -1 for a rate outside kSupportedBauds.
  absl::StatusOr<int> PeerBaud() const;

  // Master side, deadline-bounded (see SerialPort for the error contract).
  absl::Status Write(std::span<const uint8_t> bytes,
                     std::chrono::nanoseconds timeout = std::chrono::seconds(1));
  absl::StatusOr<std::vector<uint8_t>> ReadExactly(size_t n, std::chrono::nanoseconds timeout);
  // Empty on time-out.
  absl::StatusOr<std::vector<uint8_t>> ReadAvailable(std::chrono::nanoseconds timeout);

 private:
  PseudoTerminal(int master_fd, int slave_fd, std::string slave_path)
      : master_fd_(master_fd), slave_fd_(slave_fd), slave_path_(std::move(slave_path)) {}
  void Close();
  std::string Where() const;

  int master_fd_ = -1;
  int slave_fd_ = -1;
  std::string slave_path_;
  std::string symlink_path_;  // empty: none
};

}  // namespace drivegw::transport
