// SerialPort: termios setup, poll()-based reads and writes with deadlines, RS-485 turnaround.
#include "adapters/transport/serial_port.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <thread>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"

namespace drivegw::transport {
namespace {

using Clock = std::chrono::steady_clock;

std::string ErrnoText(int err) { return std::strerror(err); }

struct BaudSpeed {
  int baud;
  speed_t speed;
};

constexpr std::array<BaudSpeed, 14> kBaudTable{{
    {1200, B1200},
    {1800, B1800},
    {2400, B2400},
    {4800, B4800},
    {9600, B9600},
    {19200, B19200},
    {38400, B38400},
    {57600, B57600},
    {115200, B115200},
    {230400, B230400},
    {460800, B460800},
    {500000, B500000},
    {576000, B576000},
    {921600, B921600},
}};
static_assert(kBaudTable.size() == std::size(kSupportedBauds));

bool SpeedOf(int baud, speed_t& speed) {
  for (const auto& e : kBaudTable) {
    if (e.baud == baud) {
      speed = e.speed;
      return true;
    }
  }
  return false;
}

int BaudOf(speed_t speed) {
  for (const auto& e : kBaudTable) {
    if (e.speed == speed) return e.baud;
  }
  return -1;
}

// poll() takes milliseconds: round up so a 100 µs time-out does not become a busy 0.
int PollMillis(Clock::duration remaining) {
  if (remaining <= Clock::duration::zero()) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(remaining).count();
  return ms > 1'000'000'000 ? 1'000'000'000 : static_cast<int>(ms);
}

std::string Millis(std::chrono::nanoseconds d) {
  return absl::StrCat(std::chrono::duration_cast<std::chrono::milliseconds>(d).count(), "ms");
}

}  // namespace

absl::Status ValidateBaud(int baud) {
  speed_t speed;
  if (SpeedOf(baud, speed)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat("serial.baud: ", baud,
                                                 " is not a supported rate (",
                                                 absl::StrJoin(kSupportedBauds, ", "), ")"));
}

absl::Status ValidateSerialConfig(const SerialConfig& config) {
  if (config.device.empty()) return absl::InvalidArgumentError("serial.device: empty");
  if (absl::Status s = ValidateBaud(config.baud); !s.ok()) return s;
  if (config.turnaround < std::chrono::microseconds::zero()) {
    return absl::InvalidArgumentError(
        absl::StrCat("serial.turnaround: ", config.turnaround.count(), "us is negative"));
  }
  return absl::OkStatus();
}

std::vector<uint8_t> PartialReadBytes(const absl::Status& status) {
  std::vector<uint8_t> bytes;
  if (auto payload = status.GetPayload(kPartialReadPayloadUrl)) {
    const std::string flat(*payload);
    bytes.assign(flat.begin(), flat.end());
  }
  return bytes;
}

namespace serial_detail {

Clock::time_point DeadlineAfter(std::chrono::nanoseconds timeout) {
  const auto wait = std::clamp(timeout, std::chrono::nanoseconds::zero(),
                               std::chrono::nanoseconds(std::chrono::hours(24 * 365)));
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
}

absl::Status WithPartial(absl::Status status, const std::vector<uint8_t>& bytes) {
  status.SetPayload(kPartialReadPayloadUrl, absl::Cord(std::string(bytes.begin(), bytes.end())));
  return status;
}

absl::Status ReadUntil(int fd, int wake_fd, size_t want, bool any, Clock::time_point deadline,
                       const std::string& where, std::vector<uint8_t>& out) {
  std::array<uint8_t, 4096> buffer;
  for (;;) {
    // Drain first: with VMIN=0/VTIME=0 a raw tty read returns 0 (not EAGAIN) when empty.
    while (out.size() < want) {
      const size_t chunk = std::min(buffer.size(), want - out.size());
      const ssize_t n = ::read(fd, buffer.data(), chunk);
      if (n > 0) {
        out.insert(out.end(), buffer.begin(), buffer.begin() + n);
        continue;
      }
      if (n == 0 || errno == EAGAIN || errno == EWOULDBLOCK) break;
      if (errno == EINTR) continue;
      // EIO: the other side of a pty closed, or the USB adapter went away.
      return absl::UnavailableError(absl::StrCat(where, ": read: ", ErrnoText(errno)));
    }
    if (out.size() >= want || (any && !out.empty())) return absl::OkStatus();
    const auto remaining = deadline - Clock::now();
    if (remaining <= Clock::duration::zero()) {
      return absl::DeadlineExceededError(
          absl::StrCat(where, ": read: ", out.size(), " of ", want, " bytes before the deadline"));
    }
    std::array<pollfd, 2> fds{{{fd, POLLIN, 0}, {wake_fd, POLLIN, 0}}};
    const nfds_t count = wake_fd >= 0 ? 2 : 1;
    const int ready = ::poll(fds.data(), count, PollMillis(remaining));
    if (ready < 0) {
      if (errno == EINTR) continue;  // restart with the remaining time
      return absl::InternalError(absl::StrCat(where, ": poll: ", ErrnoText(errno)));
    }
    if (count == 2 && (fds[1].revents & POLLIN)) {
      uint64_t value = 0;
      if (::read(wake_fd, &value, sizeof(value)) == sizeof(value)) {
        return absl::CancelledError(
            absl::StrCat(where, ": read woken after ", out.size(), " of ", want, " bytes"));
      }
    }
    if ((fds[0].revents & (POLLHUP | POLLERR | POLLNVAL)) && !(fds[0].revents & POLLIN)) {
      return absl::UnavailableError(
          absl::StrCat(where, ": read: line hung up after ", out.size(), " of ", want, " bytes"));
    }
  }
}

absl::Status WriteAll(int fd, std::span<const uint8_t> bytes, Clock::time_point deadline,
                      const std::string& where, size_t& written) {
  written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n > 0) {
      written += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) {
      return absl::UnavailableError(absl::StrCat(where, ": write: ", ErrnoText(errno)));
    }
    // Output queue full: wait for room, within the deadline.
    const auto remaining = deadline - Clock::now();
    if (remaining <= Clock::duration::zero()) {
      return absl::DeadlineExceededError(absl::StrCat(where, ": write: ", written, " of ",
                                                      bytes.size(), " bytes before the deadline"));
    }
    pollfd pfd{fd, POLLOUT, 0};
    if (::poll(&pfd, 1, PollMillis(remaining)) < 0 && errno != EINTR) {
      return absl::InternalError(absl::StrCat(where, ": poll: ", ErrnoText(errno)));
    }
    if (pfd.revents & (POLLHUP | POLLERR | POLLNVAL)) {
      return absl::UnavailableError(absl::StrCat(where, ": write: line hung up after ", written,
                                                 " of ", bytes.size(), " bytes"));
    }
  }
  return absl::OkStatus();
}

}  // namespace serial_detail

absl::StatusOr<SerialPort> SerialPort::Open(const SerialConfig& config) {
  if (absl::Status s = ValidateSerialConfig(config); !s.ok()) return s;
  const std::string where = absl::StrCat("serial ", config.device);
  speed_t speed = B9600;
  SpeedOf(config.baud, speed);

  const int fd = ::open(config.device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) return absl::UnavailableError(absl::StrCat(where, ": open: ", ErrnoText(errno)));
  auto fail = [&](absl::StatusCode code, const std::string& what, int err) {
    ::close(fd);
    return absl::Status(code, absl::StrCat(where, ": ", what, ": ", ErrnoText(err)));
  };
  if (!::isatty(fd)) return fail(absl::StatusCode::kInvalidArgument, "not a terminal", errno);

  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) return fail(absl::StatusCode::kUnavailable, "tcgetattr", errno);
  // trinamic-sixpack.md §2.7: raw, 8N1 (G-03), CLOCAL|CREAD, no hardware or software flow
  // control (§2.1: CTS is ignored). VMIN=VTIME=0: reads never block, poll() does the waiting.
  ::cfmakeraw(&tio);
  tio.c_cflag &= ~(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  tio.c_iflag &= ~(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) {
    return fail(absl::StatusCode::kInvalidArgument, absl::StrCat("cfsetspeed ", config.baud),
                errno);
  }
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) {
    return fail(absl::StatusCode::kUnavailable, "tcsetattr", errno);
  }
  // tcsetattr succeeds if any one change took: read back what the driver kept.
  termios back{};
  if (::tcgetattr(fd, &back) != 0) return fail(absl::StatusCode::kUnavailable, "tcgetattr", errno);
  if (::cfgetospeed(&back) != speed || ::cfgetispeed(&back) != speed) {
    ::close(fd);
    return absl::UnavailableError(absl::StrCat(where, ": serial.baud: driver kept ",
                                               BaudOf(::cfgetospeed(&back)), " instead of ",
                                               config.baud));
  }
  if (::tcflush(fd, TCIOFLUSH) != 0) return fail(absl::StatusCode::kUnavailable, "tcflush", errno);
  const int wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) return fail(absl::StatusCode::kInternal, "eventfd", errno);
  return SerialPort(fd, wake_fd, config);
}

SerialPort::SerialPort(SerialPort&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      wake_fd_(std::exchange(other.wake_fd_, -1)),
      config_(std::move(other.config_)),
      counters_(other.counters_),
      last_rx_(other.last_rx_) {}

SerialPort& SerialPort::operator=(SerialPort&& other) noexcept {
  if (this != &other) {
    Close();
    fd_ = std::exchange(other.fd_, -1);
    wake_fd_ = std::exchange(other.wake_fd_, -1);
    config_ = std::move(other.config_);
    counters_ = other.counters_;
    last_rx_ = other.last_rx_;
  }
  return *this;
}

SerialPort::~SerialPort() { Close(); }

void SerialPort::Close() {
  if (fd_ >= 0) ::close(fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
  fd_ = -1;
  wake_fd_ = -1;
}

std::string SerialPort::Where() const { return absl::StrCat("serial ", config_.device); }

void SerialPort::NoteReceived(size_t n) {
  if (n == 0) return;
  counters_.bytes_in += n;
  last_rx_ = Clock::now();
}

absl::StatusOr<int> SerialPort::ReadBackBaud() const {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    return absl::UnavailableError(absl::StrCat(Where(), ": tcgetattr: ", ErrnoText(errno)));
  }
  return BaudOf(::cfgetospeed(&tio));
}

absl::Status SerialPort::SetBaud(int baud) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  if (absl::Status s = ValidateBaud(baud); !s.ok()) return s;
  speed_t speed = B9600;
  SpeedOf(baud, speed);
  termios tio{};
  if (::tcgetattr(fd_, &tio) != 0) {
    ++counters_.errors;
    return absl::UnavailableError(absl::StrCat(Where(), ": tcgetattr: ", ErrnoText(errno)));
  }
  if (::cfsetispeed(&tio, speed) != 0 || ::cfsetospeed(&tio, speed) != 0) {
    ++counters_.errors;
    return absl::InvalidArgumentError(
        absl::StrCat(Where(), ": cfsetspeed ", baud, ": ", ErrnoText(errno)));
  }
  // TCSADRAIN: a word still in the output queue must leave at the rate it was meant for.
  if (::tcsetattr(fd_, TCSADRAIN, &tio) != 0) {
    ++counters_.errors;
    return absl::UnavailableError(absl::StrCat(Where(), ": tcsetattr: ", ErrnoText(errno)));
  }
  termios back{};
  if (::tcgetattr(fd_, &back) != 0) {
    ++counters_.errors;
    return absl::UnavailableError(absl::StrCat(Where(), ": tcgetattr: ", ErrnoText(errno)));
  }
  if (::cfgetospeed(&back) != speed || ::cfgetispeed(&back) != speed) {
    ++counters_.errors;
    return absl::UnavailableError(absl::StrCat(Where(), ": serial.baud: driver kept ",
                                               BaudOf(::cfgetospeed(&back)), " instead of ", baud));
  }
  config_.baud = baud;
  return absl::OkStatus();
}

absl::Status SerialPort::Write(std::span<const uint8_t> bytes) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  const bool half = config_.duplex == SerialConfig::Duplex::kHalfRs485;
  if (half) {
    // §2.5 / §2.7: the PACK keeps driving the line for the switchover time after its last byte
    // (G-04 [P]); talking into that would garble both.
    std::this_thread::sleep_until(last_rx_ + config_.turnaround);
  }
  // 8N1 = 10 bit times per byte (§2.5); twice that plus a second covers a busy USB adapter.
  const auto line_time =
      std::chrono::microseconds(static_cast<int64_t>(bytes.size()) * 10 * 1'000'000 / config_.baud);
  size_t written = 0;
  absl::Status s = serial_detail::WriteAll(
      fd_, bytes, serial_detail::DeadlineAfter(2 * line_time + std::chrono::seconds(1)), Where(),
      written);
  counters_.bytes_out += written;
  if (!s.ok()) {
    if (absl::IsDeadlineExceeded(s)) {
      ++counters_.timeouts;
    } else {
      ++counters_.errors;
    }
    return s;
  }
  if (half) {
    // tcdrain: wait until the UART shifted the last bit out, then the switchover delay before
    // a reply may come or we may talk again (§2.5 L283). A pty drains at once (§2.7).
    while (::tcdrain(fd_) != 0) {
      if (errno == EINTR) continue;
      ++counters_.errors;
      return absl::UnavailableError(absl::StrCat(Where(), ": tcdrain: ", ErrnoText(errno)));
    }
    std::this_thread::sleep_until(Clock::now() + config_.turnaround);
  }
  return absl::OkStatus();
}

absl::StatusOr<std::vector<uint8_t>> SerialPort::ReadExactly(size_t n,
                                                             std::chrono::nanoseconds timeout) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  std::vector<uint8_t> out;
  out.reserve(n);
  absl::Status s = serial_detail::ReadUntil(fd_, wake_fd_, n, /*any=*/false,
                                            serial_detail::DeadlineAfter(timeout), Where(), out);
  NoteReceived(out.size());
  if (s.ok()) return out;
  if (absl::IsDeadlineExceeded(s)) {
    ++counters_.timeouts;
    s = absl::DeadlineExceededError(absl::StrCat(Where(), ": read: ", out.size(), " of ", n,
                                                 " bytes within ", Millis(timeout)));
  } else if (absl::IsCancelled(s)) {
    ++counters_.wakeups;
  } else {
    ++counters_.errors;
  }
  return serial_detail::WithPartial(std::move(s), out);
}

absl::StatusOr<std::vector<uint8_t>> SerialPort::ReadAvailable(std::chrono::nanoseconds timeout) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  std::vector<uint8_t> out;
  absl::Status s = serial_detail::ReadUntil(fd_, wake_fd_, SIZE_MAX, /*any=*/true,
                                            serial_detail::DeadlineAfter(timeout), Where(), out);
  NoteReceived(out.size());
  if (s.ok() || absl::IsDeadlineExceeded(s)) return out;
  if (absl::IsCancelled(s)) {
    ++counters_.wakeups;
    return out;
  }
  ++counters_.errors;
  return s;
}

absl::Status SerialPort::Flush() {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  int pending = 0;
  if (::ioctl(fd_, FIONREAD, &pending) != 0) pending = 0;  // only for the counter
  if (::tcflush(fd_, TCIFLUSH) != 0) {
    ++counters_.errors;
    return absl::UnavailableError(absl::StrCat(Where(), ": tcflush: ", ErrnoText(errno)));
  }
  ++counters_.flushes;
  counters_.bytes_flushed += static_cast<uint64_t>(std::max(pending, 0));
  return absl::OkStatus();
}

absl::Status SerialPort::SendBreak(std::chrono::milliseconds duration) {
  if (fd_ < 0) return absl::FailedPreconditionError(absl::StrCat(Where(), ": closed"));
  if (duration <= std::chrono::milliseconds::zero()) {
    if (::tcsendbreak(fd_, 0) != 0) {
      ++counters_.errors;
      return absl::UnavailableError(absl::StrCat(Where(), ": tcsendbreak: ", ErrnoText(errno)));
    }
  } else {
    if (::ioctl(fd_, TIOCSBRK) != 0) {
      ++counters_.errors;
      return absl::UnavailableError(absl::StrCat(Where(), ": TIOCSBRK: ", ErrnoText(errno)));
    }
    std::this_thread::sleep_for(duration);
    if (::ioctl(fd_, TIOCCBRK) != 0) {
      ++counters_.errors;
      return absl::UnavailableError(absl::StrCat(Where(), ": TIOCCBRK: ", ErrnoText(errno)));
    }
  }
  ++counters_.breaks;
  return absl::OkStatus();
}

void SerialPort::Wake() {
  if (wake_fd_ < 0) return;
  const uint64_t one = 1;
  // EAGAIN only when the counter would overflow: a wake-up is pending anyway.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

}  // namespace drivegw::transport
