// UdpSocket: non-blocking IPv4 datagram socket, poll() on the socket plus an eventfd for wake-up.
#include "adapters/transport/udp_socket.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {
namespace {

using Clock = std::chrono::steady_clock;

std::string ErrnoText(int err) { return std::strerror(err); }

sockaddr_in ToSockaddr(const Endpoint& e) {
  sockaddr_in sa{};
  sa.sin_family = AF_INET;
  sa.sin_addr.s_addr = htonl(e.ipv4);
  sa.sin_port = htons(e.port);
  return sa;
}

Endpoint FromSockaddr(const sockaddr_in& sa) {
  return Endpoint{ntohl(sa.sin_addr.s_addr), ntohs(sa.sin_port)};
}

// poll() takes milliseconds: round up so a 100 µs time-out does not become a busy 0.
int PollMillis(Clock::duration remaining) {
  if (remaining <= Clock::duration::zero()) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(remaining).count();
  return ms > 1'000'000'000 ? 1'000'000'000 : static_cast<int>(ms);
}

}  // namespace

absl::StatusOr<UdpSocket> UdpSocket::Bind(const Endpoint& local, BindOptions options) {
  const std::string where = absl::StrCat("udp bind ", local.ToString(), ": ");
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) return absl::InternalError(absl::StrCat(where, "socket: ", ErrnoText(errno)));
  const int one = 1;
  if (options.reuse_address && ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) != 0) {
    const int err = errno;
    ::close(fd);
    return absl::InternalError(absl::StrCat(where, "SO_REUSEADDR: ", ErrnoText(err)));
  }
  sockaddr_in sa = ToSockaddr(local);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&sa), sizeof(sa)) != 0) {
    const int err = errno;
    ::close(fd);
    // EADDRINUSE / EADDRNOTAVAIL are configuration problems, not our bugs.
    if (err == EADDRINUSE || err == EADDRNOTAVAIL || err == EACCES) {
      return absl::UnavailableError(absl::StrCat(where, ErrnoText(err)));
    }
    return absl::InternalError(absl::StrCat(where, ErrnoText(err)));
  }
  sockaddr_in bound{};
  socklen_t len = sizeof(bound);
  if (::getsockname(fd, reinterpret_cast<sockaddr*>(&bound), &len) != 0) {
    const int err = errno;
    ::close(fd);
    return absl::InternalError(absl::StrCat(where, "getsockname: ", ErrnoText(err)));
  }
  const int wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (wake_fd < 0) {
    const int err = errno;
    ::close(fd);
    return absl::InternalError(absl::StrCat(where, "eventfd: ", ErrnoText(err)));
  }
  return UdpSocket(fd, wake_fd, FromSockaddr(bound));
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      wake_fd_(std::exchange(other.wake_fd_, -1)),
      local_(other.local_),
      shut_down_(other.shut_down_.load()),
      sent_(other.sent_.load()),
      received_(other.received_.load()),
      send_errors_(other.send_errors_.load()),
      receive_errors_(other.receive_errors_.load()),
      truncated_(other.truncated_.load()) {}

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    Close();
    fd_ = std::exchange(other.fd_, -1);
    wake_fd_ = std::exchange(other.wake_fd_, -1);
    local_ = other.local_;
    shut_down_ = other.shut_down_.load();
    sent_ = other.sent_.load();
    received_ = other.received_.load();
    send_errors_ = other.send_errors_.load();
    receive_errors_ = other.receive_errors_.load();
    truncated_ = other.truncated_.load();
  }
  return *this;
}

UdpSocket::~UdpSocket() { Close(); }

void UdpSocket::Close() {
  if (fd_ >= 0) ::close(fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
  fd_ = -1;
  wake_fd_ = -1;
}

absl::Status UdpSocket::SendTo(const Endpoint& to, std::span<const uint8_t> bytes) {
  if (is_shut_down() || fd_ < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("udp ", local_.ToString(), " -> ", to.ToString(), ": socket shut down"));
  }
  const sockaddr_in sa = ToSockaddr(to);
  for (;;) {
    const ssize_t n = ::sendto(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL,
                               reinterpret_cast<const sockaddr*>(&sa), sizeof(sa));
    if (n >= 0) {
      sent_.fetch_add(1, std::memory_order_relaxed);
      return absl::OkStatus();
    }
    if (errno == EINTR) continue;
    const int err = errno;
    send_errors_.fetch_add(1, std::memory_order_relaxed);
    return absl::UnavailableError(absl::StrCat("udp ", local_.ToString(), " -> ", to.ToString(),
                                               ": sendto ", bytes.size(),
                                               " bytes: ", ErrnoText(err)));
  }
}

absl::StatusOr<std::optional<Datagram>> UdpSocket::Receive(std::chrono::nanoseconds timeout) {
  // Clamped so that now + timeout cannot overflow (nanoseconds::max() means "a long time").
  const auto wait = std::clamp(timeout, std::chrono::nanoseconds::zero(),
                               std::chrono::nanoseconds(std::chrono::hours(24 * 365)));
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
  for (;;) {
    if (is_shut_down() || fd_ < 0) {
      return absl::CancelledError(absl::StrCat("udp ", local_.ToString(), ": socket shut down"));
    }
    std::array<pollfd, 2> fds{{{fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}}};
    const int ready = ::poll(fds.data(), fds.size(), PollMillis(deadline - Clock::now()));
    if (ready < 0) {
      if (errno == EINTR) continue;  // restart with the remaining time
      const int err = errno;
      receive_errors_.fetch_add(1, std::memory_order_relaxed);
      return absl::InternalError(
          absl::StrCat("udp ", local_.ToString(), ": poll: ", ErrnoText(err)));
    }
    if (fds[1].revents & POLLIN) {
      if (is_shut_down()) continue;  // reported above; the eventfd stays readable for others
      uint64_t value = 0;
      // Consume the wake-up; a concurrent receiver may have taken it first (EAGAIN).
      if (::read(wake_fd_, &value, sizeof(value)) == sizeof(value)) return std::nullopt;
    }
    if (fds[0].revents & (POLLIN | POLLERR)) {
      // Stack buffer: receivers on several threads must not share one.
      std::array<uint8_t, kMaxDatagramSize> buffer;
      sockaddr_in from{};
      socklen_t from_len = sizeof(from);
      const ssize_t n = ::recvfrom(fd_, buffer.data(), buffer.size(), MSG_TRUNC,
                                   reinterpret_cast<sockaddr*>(&from), &from_len);
      if (n >= 0) {
        size_t size = static_cast<size_t>(n);
        if (size > buffer.size()) {
          truncated_.fetch_add(1, std::memory_order_relaxed);
          size = buffer.size();
        }
        received_.fetch_add(1, std::memory_order_relaxed);
        return Datagram{FromSockaddr(from),
                        std::vector<uint8_t>(buffer.begin(), buffer.begin() + size)};
      }
      const int err = errno;
      // EAGAIN: another receiver took it; ECONNREFUSED: ICMP for an earlier send, not fatal.
      if (err != EAGAIN && err != EWOULDBLOCK && err != EINTR && err != ECONNREFUSED) {
        receive_errors_.fetch_add(1, std::memory_order_relaxed);
        return absl::InternalError(
            absl::StrCat("udp ", local_.ToString(), ": recvfrom: ", ErrnoText(err)));
      }
    }
    if (Clock::now() >= deadline) return std::nullopt;
  }
}

void UdpSocket::Wake() {
  if (wake_fd_ < 0) return;
  const uint64_t one = 1;
  // EAGAIN only when the counter would overflow: a wake-up is pending anyway.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

void UdpSocket::Shutdown() {
  shut_down_.store(true, std::memory_order_release);
  Wake();
}

UdpSocketCounters UdpSocket::counters() const {
  UdpSocketCounters c;
  c.sent = sent_.load(std::memory_order_relaxed);
  c.received = received_.load(std::memory_order_relaxed);
  c.send_errors = send_errors_.load(std::memory_order_relaxed);
  c.receive_errors = receive_errors_.load(std::memory_order_relaxed);
  c.truncated = truncated_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace drivegw::transport
