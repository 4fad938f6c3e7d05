// RAII IPv4 UDP socket: bind, send, poll()-based receive with time-out, and a wake-up for
// threads blocked in Receive (linmot-linudp.md 1.1: one telegram = one datagram).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/endpoint.h"

namespace drivegw::transport {

struct Datagram {
  Endpoint from;
  std::vector<uint8_t> bytes;
};

// One slot of a batch receive (UdpSocket::ReceiveBatch): the caller owns `buffer`, so that a
// receive loop allocates nothing per datagram.
struct DatagramSlot {
  std::span<uint8_t> buffer;  // where the payload goes
  Endpoint from;              // filled by ReceiveBatch
  size_t size = 0;            // payload bytes stored in buffer (cut to buffer.size())
  bool truncated = false;     // the datagram was longer than buffer
};

// One datagram of a batch send (UdpSocket::SendBatch).
struct OutgoingDatagram {
  Endpoint to;
  std::span<const uint8_t> bytes;
};

struct UdpSocketCounters {
  uint64_t sent = 0;            // datagrams handed to the kernel
  uint64_t received = 0;        // datagrams returned by Receive
  uint64_t send_errors = 0;     // SendTo failures
  uint64_t receive_errors = 0;  // recvfrom failures other than EAGAIN/EINTR
  uint64_t truncated = 0;       // received datagrams larger than kMaxDatagramSize (cut)
};

// Move-only; the destructor closes the socket. SendTo, SendBatch, Receive, Wake, Shutdown and
// counters() may be called from different threads at the same time; moving or destroying may not
// overlap any other call.
class UdpSocket {
 public:
  static constexpr size_t kMaxDatagramSize = 65507;  // largest IPv4 UDP payload
  static constexpr size_t kMaxBatch = 64;            // datagrams per recvmmsg/sendmmsg call

  struct BindOptions {
    // SO_REUSEADDR. On Linux this lets a second UDP socket bind the very same address while
    // the first is open (both set it) and the kernel then hands unicast datagrams to only one
    // of them; false makes such a collision an error (docs/decisions/202-udp-reuseaddr.md).
    bool reuse_address = false;
  };

  // Binds `local` (port 0 = ephemeral), non-blocking. Errors name the address and the errno
  // text: "udp bind 127.0.0.1:41136: Address already in use" (Unavailable for address in use
  // or not available, Internal otherwise).
  static absl::StatusOr<UdpSocket> Bind(const Endpoint& local, BindOptions options);
  static absl::StatusOr<UdpSocket> Bind(const Endpoint& local) { return Bind(local, {}); }

  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;
  ~UdpSocket();

  // The bound address; the port is the one the kernel chose when Bind was given port 0.
  const Endpoint& local_endpoint() const { return local_; }
  uint16_t local_port() const { return local_.port; }
  // The descriptor, for an event loop that waits on many sockets (epoll); still owned here.
  int native_handle() const { return fd_; }

  // One datagram to `to`. Unavailable (counted) when the kernel refuses it, e.g. a full buffer;
  // FailedPrecondition after Shutdown.
  absl::Status SendTo(const Endpoint& to, std::span<const uint8_t> bytes);

  // Waits up to `timeout` (<= 0: just checks) for one datagram. nullopt on time-out or when
  // Wake() was called; CancelledError once Shutdown() was called; Internal for socket errors.
  // EINTR restarts the wait with the remaining time.
  absl::StatusOr<std::optional<Datagram>> Receive(std::chrono::nanoseconds timeout);

  // Allocation-free batch receive for a single-reader loop: waits like Receive (up to `timeout`,
  // Wake ends the wait), then takes every datagram already queued, up to slots.size(), with one
  // recvmmsg(2). Returns how many slots were filled: 0 on time-out or wake-up. CancelledError
  // once Shutdown() was called; Internal for socket errors.
  absl::StatusOr<size_t> ReceiveBatch(std::span<DatagramSlot> slots,
                                      std::chrono::nanoseconds timeout);

  // The same without waiting (for a loop that waits on many sockets itself): one recvmmsg with
  // MSG_DONTWAIT; 0 when nothing is queued.
  absl::StatusOr<size_t> TryReceiveBatch(std::span<DatagramSlot> slots);

  // Sends every datagram with as few sendmmsg(2) calls as the kernel allows. Returns how many
  // were sent; `failed`, when given, receives the index of each one the kernel refused (counted
  // like SendTo errors; the others are still sent). FailedPrecondition after Shutdown.
  absl::StatusOr<size_t> SendBatch(std::span<const OutgoingDatagram> out,
                                   std::vector<size_t>* failed = nullptr);

  // Makes one blocked (or the next) Receive return nullopt at once. Thread-safe.
  void Wake();
  // Releases every blocked Receive for good: Receive and SendTo fail from now on. Idempotent,
  // thread-safe; the descriptor itself is closed by the destructor.
  void Shutdown();
  bool is_shut_down() const { return shut_down_.load(std::memory_order_acquire); }

  UdpSocketCounters counters() const;

 private:
  UdpSocket(int fd, int wake_fd, Endpoint local) : fd_(fd), wake_fd_(wake_fd), local_(local) {}
  void Close();
  // poll() on the socket and the wake-up eventfd with nanosecond resolution (ppoll), restarting
  // on EINTR: kReadable, kWoken, kTimedOut; CancelledError after Shutdown.
  enum class WaitResult { kReadable, kWoken, kTimedOut };
  absl::StatusOr<WaitResult> WaitReadable(std::chrono::nanoseconds timeout);

  int fd_ = -1;
  int wake_fd_ = -1;  // eventfd: readable while a wake-up is pending
  Endpoint local_;
  std::atomic<bool> shut_down_{false};
  std::atomic<uint64_t> sent_{0};
  std::atomic<uint64_t> received_{0};
  std::atomic<uint64_t> send_errors_{0};
  std::atomic<uint64_t> receive_errors_{0};
  std::atomic<uint64_t> truncated_{0};
};

}  // namespace drivegw::transport
