// PseudoTerminal: openpty() pair in raw mode, optional symlink, deadline-bounded master I/O.
#include "adapters/transport/pty.h"

#include <fcntl.h>
#include <pty.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <climits>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "adapters/transport/serial_port.h"

namespace drivegw::transport {
namespace {

std::string ErrnoText(int err) { return std::strerror(err); }

int BaudOf(speed_t speed) {
  static constexpr std::array<std::pair<speed_t, int>, 14> kTable{{
      {B1200, 1200},
      {B1800, 1800},
      {B2400, 2400},
      {B4800, 4800},
      {B9600, 9600},
      {B19200, 19200},
      {B38400, 38400},
      {B57600, 57600},
      {B115200, 115200},
      {B230400, 230400},
      {B460800, 460800},
      {B500000, 500000},
      {B576000, 576000},
      {B921600, 921600},
  }};
  for (const auto& [s, b] : kTable) {
    if (s == speed) return b;
  }
  return -1;
}

// Where a symlink points, or "" if `path` is not a symlink.
std::string LinkTarget(const std::string& path) {
  std::array<char, PATH_MAX> buf{};
  const ssize_t n = ::readlink(path.c_str(), buf.data(), buf.size() - 1);
  return n > 0 ? std::string(buf.data(), static_cast<size_t>(n)) : std::string();
}

}  // namespace

absl::StatusOr<PseudoTerminal> PseudoTerminal::Open(const std::string& symlink_path) {
  int master = -1;
  int slave = -1;
  if (::openpty(&master, &slave, nullptr, nullptr, nullptr) != 0) {
    return absl::UnavailableError(absl::StrCat("pty: openpty: ", ErrnoText(errno)));
  }
  std::array<char, PATH_MAX> name{};
  if (::ttyname_r(slave, name.data(), name.size()) != 0) {
    const int err = errno;
    ::close(master);
    ::close(slave);
    return absl::InternalError(absl::StrCat("pty: ttyname: ", ErrnoText(err)));
  }
  PseudoTerminal pty(master, slave, name.data());
  // Both ends share one termios (trinamic-sixpack.md §2.7): raw here, so nothing is echoed or
  // translated before the adapter opens the slave and sets its own speed.
  termios tio{};
  if (::tcgetattr(slave, &tio) != 0) {
    return absl::InternalError(absl::StrCat(pty.Where(), ": tcgetattr: ", ErrnoText(errno)));
  }
  ::cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (::tcsetattr(slave, TCSANOW, &tio) != 0 || ::tcsetattr(master, TCSANOW, &tio) != 0) {
    return absl::InternalError(absl::StrCat(pty.Where(), ": tcsetattr: ", ErrnoText(errno)));
  }
  for (int fd : {master, slave}) {
    const int flags = ::fcntl(fd, F_GETFL);
    if (flags < 0 || ::fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0 ||
        ::fcntl(fd, F_SETFD, FD_CLOEXEC) != 0) {
      return absl::InternalError(absl::StrCat(pty.Where(), ": fcntl: ", ErrnoText(errno)));
    }
  }
  if (!symlink_path.empty()) {
    struct stat st {};
    if (::lstat(symlink_path.c_str(), &st) == 0) {
      if (!S_ISLNK(st.st_mode)) {
        return absl::AlreadyExistsError(
            absl::StrCat("pty symlink ", symlink_path, ": exists and is not a symlink"));
      }
      // A previous simulator that crashed left its link behind: replace it.
      if (::unlink(symlink_path.c_str()) != 0) {
        return absl::UnavailableError(
            absl::StrCat("pty symlink ", symlink_path, ": unlink: ", ErrnoText(errno)));
      }
    }
    if (::symlink(pty.slave_path_.c_str(), symlink_path.c_str()) != 0) {
      return absl::UnavailableError(
          absl::StrCat("pty symlink ", symlink_path, ": symlink: ", ErrnoText(errno)));
    }
    pty.symlink_path_ = symlink_path;
  }
  return pty;
}

PseudoTerminal::PseudoTerminal(PseudoTerminal&& other) noexcept
    : master_fd_(std::exchange(other.master_fd_, -1)),
      slave_fd_(std::exchange(other.slave_fd_, -1)),
      slave_path_(std::move(other.slave_path_)),
      symlink_path_(std::exchange(other.symlink_path_, std::string())) {}

PseudoTerminal& PseudoTerminal::operator=(PseudoTerminal&& other) noexcept {
  if (this != &other) {
    Close();
    master_fd_ = std::exchange(other.master_fd_, -1);
    slave_fd_ = std::exchange(other.slave_fd_, -1);
    slave_path_ = std::move(other.slave_path_);
    symlink_path_ = std::exchange(other.symlink_path_, std::string());
  }
  return *this;
}

PseudoTerminal::~PseudoTerminal() { Close(); }

void PseudoTerminal::Close() {
  // Remove the link only while it is still ours: a newer simulator may have replaced it.
  if (!symlink_path_.empty() && LinkTarget(symlink_path_) == slave_path_) {
    ::unlink(symlink_path_.c_str());
  }
  symlink_path_.clear();
  if (master_fd_ >= 0) ::close(master_fd_);
  if (slave_fd_ >= 0) ::close(slave_fd_);
  master_fd_ = -1;
  slave_fd_ = -1;
}

std::string PseudoTerminal::Where() const { return absl::StrCat("pty ", slave_path_); }

absl::StatusOr<int> PseudoTerminal::PeerBaud() const {
  termios tio{};
  if (master_fd_ < 0 || ::tcgetattr(master_fd_, &tio) != 0) {
    return absl::UnavailableError(absl::StrCat(Where(), ": tcgetattr: ", ErrnoText(errno)));
  }
  return BaudOf(::cfgetospeed(&tio));
}

absl::Status PseudoTerminal::Write(std::span<const uint8_t> bytes,
                                   std::chrono::nanoseconds timeout) {
  if (master_fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  size_t written = 0;
  return serial_detail::WriteAll(master_fd_, bytes, serial_detail::DeadlineAfter(timeout), Where(),
                                 written);
}

absl::StatusOr<std::vector<uint8_t>> PseudoTerminal::ReadExactly(size_t n,
                                                                 std::chrono::nanoseconds timeout) {
  if (master_fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  std::vector<uint8_t> out;
  absl::Status s = serial_detail::ReadUntil(master_fd_, -1, n, /*any=*/false,
                                            serial_detail::DeadlineAfter(timeout), Where(), out);
  if (s.ok()) return out;
  return serial_detail::WithPartial(std::move(s), out);
}

absl::StatusOr<std::vector<uint8_t>> PseudoTerminal::ReadAvailable(
    std::chrono::nanoseconds timeout) {
  if (master_fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  std::vector<uint8_t> out;
  absl::Status s = serial_detail::ReadUntil(master_fd_, -1, SIZE_MAX, /*any=*/true,
                                            serial_detail::DeadlineAfter(timeout), Where(), out);
  if (s.ok() || absl::IsDeadlineExceeded(s)) return out;
  return s;
}

}  // namespace drivegw::transport
