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

timespec ToTimespec(Clock::duration remaining) {
  if (remaining <= Clock::duration::zero()) return timespec{0, 0};
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(remaining).count();
  return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
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

absl::StatusOr<UdpSocket::WaitResult> UdpSocket::WaitReadable(std::chrono::nanoseconds timeout) {
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
    // ppoll, not poll: a cyclic exchange at 1-2 ms cannot live with poll()'s whole milliseconds
    // (rounded up, every wait overslept by up to 1 ms; issue 10, P2).
    const timespec ts = ToTimespec(deadline - Clock::now());
    const int ready = ::ppoll(fds.data(), fds.size(), &ts, nullptr);
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
      if (::read(wake_fd_, &value, sizeof(value)) == sizeof(value)) return WaitResult::kWoken;
    }
    if (fds[0].revents & (POLLIN | POLLERR)) return WaitResult::kReadable;
    if (Clock::now() >= deadline) return WaitResult::kTimedOut;
  }
}

absl::StatusOr<std::optional<Datagram>> UdpSocket::Receive(std::chrono::nanoseconds timeout) {
  const auto wait = std::clamp(timeout, std::chrono::nanoseconds::zero(),
                               std::chrono::nanoseconds(std::chrono::hours(24 * 365)));
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(wait);
  for (;;) {
    absl::StatusOr<WaitResult> w = WaitReadable(deadline - Clock::now());
    if (!w.ok()) return w.status();
    if (*w != WaitResult::kReadable) return std::nullopt;
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
    if (Clock::now() >= deadline) return std::nullopt;
  }
}

absl::StatusOr<size_t> UdpSocket::ReceiveBatch(std::span<DatagramSlot> slots,
                                               std::chrono::nanoseconds timeout) {
  if (slots.empty()) return 0;
  absl::StatusOr<WaitResult> w = WaitReadable(timeout);
  if (!w.ok()) return w.status();
  if (*w != WaitResult::kReadable) return 0;
  return TryReceiveBatch(slots);
}

absl::StatusOr<size_t> UdpSocket::TryReceiveBatch(std::span<DatagramSlot> slots) {
  if (is_shut_down() || fd_ < 0) {
    return absl::CancelledError(absl::StrCat("udp ", local_.ToString(), ": socket shut down"));
  }
  std::array<mmsghdr, kMaxBatch> msgs{};
  std::array<iovec, kMaxBatch> iov{};
  std::array<sockaddr_in, kMaxBatch> from{};
  const size_t n = std::min(slots.size(), kMaxBatch);
  for (size_t i = 0; i < n; ++i) {
    iov[i] = {slots[i].buffer.data(), slots[i].buffer.size()};
    msgs[i].msg_hdr.msg_iov = &iov[i];
    msgs[i].msg_hdr.msg_iovlen = 1;
    msgs[i].msg_hdr.msg_name = &from[i];
    msgs[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
  }
  for (;;) {
    const int got = ::recvmmsg(fd_, msgs.data(), static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
    if (got >= 0) {
      uint64_t truncated = 0;
      for (size_t i = 0; i < static_cast<size_t>(got); ++i) {
        DatagramSlot& s = slots[i];
        s.from = FromSockaddr(from[i]);
        s.truncated = (msgs[i].msg_hdr.msg_flags & MSG_TRUNC) != 0;
        s.size = std::min<size_t>(msgs[i].msg_len, s.buffer.size());
        truncated += s.truncated ? 1 : 0;
      }
      received_.fetch_add(static_cast<uint64_t>(got), std::memory_order_relaxed);
      if (truncated != 0) truncated_.fetch_add(truncated, std::memory_order_relaxed);
      return static_cast<size_t>(got);
    }
    const int err = errno;
    if (err == EINTR) continue;
    // EAGAIN: another receiver took it; ECONNREFUSED: ICMP for an earlier send, not fatal.
    if (err == EAGAIN || err == EWOULDBLOCK || err == ECONNREFUSED) return 0;
    receive_errors_.fetch_add(1, std::memory_order_relaxed);
    return absl::InternalError(
        absl::StrCat("udp ", local_.ToString(), ": recvmmsg: ", ErrnoText(err)));
  }
}

absl::StatusOr<size_t> UdpSocket::SendBatch(std::span<const OutgoingDatagram> out,
                                            std::vector<size_t>* failed) {
  if (is_shut_down() || fd_ < 0) {
    return absl::FailedPreconditionError(
        absl::StrCat("udp ", local_.ToString(), ": socket shut down"));
  }
  std::array<mmsghdr, kMaxBatch> msgs{};
  std::array<iovec, kMaxBatch> iov{};
  std::array<sockaddr_in, kMaxBatch> to{};
  size_t sent = 0;
  size_t next = 0;
  while (next < out.size()) {
    const size_t n = std::min(out.size() - next, kMaxBatch);
    for (size_t i = 0; i < n; ++i) {
      const OutgoingDatagram& d = out[next + i];
      to[i] = ToSockaddr(d.to);
      iov[i] = {const_cast<uint8_t*>(d.bytes.data()), d.bytes.size()};
      msgs[i] = {};
      msgs[i].msg_hdr.msg_iov = &iov[i];
      msgs[i].msg_hdr.msg_iovlen = 1;
      msgs[i].msg_hdr.msg_name = &to[i];
      msgs[i].msg_hdr.msg_namelen = sizeof(sockaddr_in);
    }
    const int got = ::sendmmsg(fd_, msgs.data(), static_cast<unsigned>(n), MSG_NOSIGNAL);
    if (got > 0) {
      sent += static_cast<size_t>(got);
      next += static_cast<size_t>(got);
      continue;
    }
    if (got < 0 && errno == EINTR) continue;
    // The first datagram of the rest was refused (e.g. a full buffer): count it, go on.
    send_errors_.fetch_add(1, std::memory_order_relaxed);
    if (failed != nullptr) failed->push_back(next);
    ++next;
  }
  sent_.fetch_add(sent, std::memory_order_relaxed);
  return sent;
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
