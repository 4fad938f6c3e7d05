// UdpMulticastChannel: python-can udp_multicast wire format over two IPv4 UDP sockets (a
// receiver bound to the group, a sender on an ephemeral port) plus an eventfd for Wake.
#include "adapters/transport/udp_multicast_channel.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"
#include "adapters/transport/msgpack_lite.h"

namespace drivegw::transport {
namespace {

using SteadyTime = std::chrono::steady_clock;

std::string ErrnoText(int err) { return std::strerror(err); }

// poll() takes milliseconds: round up so a 100 µs time-out does not become a busy 0.
int PollMillis(SteadyTime::duration remaining) {
  if (remaining <= SteadyTime::duration::zero()) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(remaining).count();
  return ms > 1'000'000'000 ? 1'000'000'000 : static_cast<int>(ms);
}

// What the operator can do when the host has no route for the group (measured in a fresh
// network namespace: IP_ADD_MEMBERSHIP gives ENODEV, sendto ENETUNREACH; docs/decisions/802).
constexpr char kRouteHint[] =
    "this host has no route for IPv4 multicast; add one, e.g. "
    "'ip route add 224.0.0.0/4 dev lo' (and 'ip link set lo multicast on'), or give the "
    "host a default route";

constexpr std::chrono::milliseconds kSendWait{100};

// A paced receiver wakes this long before a held frame's end and spins the rest (decision 805).
constexpr std::chrono::microseconds kHoldSpin{75};

inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

double WallSeconds() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

bool IsRouteError(int err) {
  return err == ENODEV || err == ENETUNREACH || err == EHOSTUNREACH || err == ENETDOWN;
}

// The keys python-can 4.1's can.Message.__init__ accepts (unpack_message passes the dict as
// keyword arguments, so any other key is a TypeError there, and malformed here).
enum class Key {
  kTimestamp,
  kArbitrationId,
  kIsExtendedId,
  kIsRemoteFrame,
  kIsErrorFrame,
  kChannel,
  kDlc,
  kData,
  kIsFd,
  kIsRx,
  kBitrateSwitch,
  kErrorStateIndicator,
  kCheck,
  kUnknown
};

Key LookupKey(std::string_view k) {
  static constexpr std::pair<std::string_view, Key> kKeys[] = {
      {"timestamp", Key::kTimestamp},
      {"arbitration_id", Key::kArbitrationId},
      {"is_extended_id", Key::kIsExtendedId},
      {"is_remote_frame", Key::kIsRemoteFrame},
      {"is_error_frame", Key::kIsErrorFrame},
      {"channel", Key::kChannel},
      {"dlc", Key::kDlc},
      {"data", Key::kData},
      {"is_fd", Key::kIsFd},
      {"is_rx", Key::kIsRx},
      {"bitrate_switch", Key::kBitrateSwitch},
      {"error_state_indicator", Key::kErrorStateIndicator},
      {"check", Key::kCheck}};
  for (const auto& [name, key] : kKeys) {
    if (name == k) return key;
  }
  return Key::kUnknown;
}

absl::Status MessageError(std::string_view key, absl::string_view what) {
  return absl::InvalidArgumentError(
      absl::StrCat("python-can message.", std::string(key), ": ", what));
}

// Python truthiness is what can.Message uses for its flags; msgpack-python writes bool, and
// nil (None) is falsy. Anything else is refused rather than guessed.
absl::StatusOr<bool> ReadFlag(msgpack::Reader& r, std::string_view key) {
  auto type = r.PeekType();
  if (type.ok() && *type == msgpack::Type::kNil) {
    if (r.ReadNil().ok()) return false;
  }
  auto b = r.ReadBool();
  if (!b.ok()) return MessageError(key, b.status().message());
  return *b;
}

}  // namespace

std::vector<uint8_t> EncodePythonCanMessage(const CanFrame& frame, double timestamp_s) {
  msgpack::Writer w;
  w.MapHeader(11);
  w.Str("timestamp");
  w.Float64(timestamp_s);
  w.Str("arbitration_id");
  w.Uint(frame.id);
  w.Str("is_extended_id");
  w.Bool(frame.extended);
  w.Str("is_remote_frame");
  w.Bool(frame.rtr);
  w.Str("is_error_frame");
  w.Bool(frame.error);
  w.Str("channel");
  w.Nil();
  w.Str("dlc");
  w.Uint(frame.dlc);
  w.Str("data");
  w.Bin(frame.payload());  // empty for RTR: python-can requires it ("remote frames may not carry
                           // any data")
  w.Str("is_fd");
  w.Bool(false);
  w.Str("bitrate_switch");
  w.Bool(false);
  w.Str("error_state_indicator");
  w.Bool(false);
  return w.Take();
}

absl::StatusOr<CanFrame> DecodePythonCanMessage(std::span<const uint8_t> datagram,
                                                double* timestamp_s) {
  msgpack::Reader r(datagram);
  auto entries = r.ReadMapHeader();
  if (!entries.ok()) return MessageError("", entries.status().message());
  // can.Message defaults (python-can 4.1 message.py): note is_extended_id=True.
  double timestamp = 0;
  int64_t arbitration_id = 0;
  bool extended = true, remote = false, error = false, fd = false, brs = false, esi = false;
  int64_t dlc = 0;  // with has_dlc; std::optional trips GCC 12's -Wmaybe-uninitialized
  bool has_dlc = false;
  std::vector<uint8_t> data;
  for (uint32_t i = 0; i < *entries; ++i) {
    auto key_text = r.ReadStr();
    if (!key_text.ok()) return MessageError("", absl::StrCat("key ", key_text.status().message()));
    const std::string key(*key_text);
    switch (LookupKey(*key_text)) {
      case Key::kTimestamp: {
        auto t = r.ReadFloat();
        if (!t.ok()) return MessageError(key, t.status().message());
        if (std::isnan(*t) || std::isinf(*t) || *t < 0) {
          return MessageError(key, "negative, infinite or NaN");
        }
        timestamp = *t;
        break;
      }
      case Key::kArbitrationId: {
        auto v = r.ReadInt();
        if (!v.ok()) return MessageError(key, v.status().message());
        arbitration_id = *v;
        break;
      }
      case Key::kDlc: {
        auto type = r.PeekType();
        if (type.ok() && *type == msgpack::Type::kNil) {
          (void)r.ReadNil();
          has_dlc = false;
          break;
        }
        auto v = r.ReadInt();
        if (!v.ok()) return MessageError(key, v.status().message());
        dlc = *v;
        has_dlc = true;
        break;
      }
      case Key::kData: {
        auto type = r.PeekType();
        if (!type.ok()) return MessageError(key, type.status().message());
        data.clear();
        if (*type == msgpack::Type::kNil) {
          (void)r.ReadNil();
        } else if (*type == msgpack::Type::kBin) {
          auto bin = r.ReadBin();
          if (!bin.ok()) return MessageError(key, bin.status().message());
          if (bin->size() > 64)
            return MessageError(key, absl::StrCat(bin->size(), " bytes exceed 64"));
          data.assign(bin->begin(), bin->end());
        } else if (*type == msgpack::Type::kArray) {
          // bytearray(list of ints): what a hand-written dict may carry.
          auto n = r.ReadArrayHeader();
          if (!n.ok()) return MessageError(key, n.status().message());
          if (*n > 64) return MessageError(key, absl::StrCat(*n, " bytes exceed 64"));
          for (uint32_t j = 0; j < *n; ++j) {
            auto b = r.ReadInt();
            if (!b.ok() || *b < 0 || *b > 255)
              return MessageError(key, "array element is not a byte");
            data.push_back(static_cast<uint8_t>(*b));
          }
        } else {
          return MessageError(key, "is neither bin nor an array of bytes");
        }
        break;
      }
      case Key::kChannel:
      case Key::kCheck: {  // channel: any value (str, int, nil); check: overridden by python-can
        absl::Status s = r.Skip();
        if (!s.ok()) return MessageError(key, s.message());
        break;
      }
      case Key::kIsExtendedId:
      case Key::kIsRemoteFrame:
      case Key::kIsErrorFrame:
      case Key::kIsFd:
      case Key::kIsRx:
      case Key::kBitrateSwitch:
      case Key::kErrorStateIndicator: {
        auto flag = ReadFlag(r, key);
        if (!flag.ok()) return flag.status();
        const Key k = LookupKey(*key_text);
        if (k == Key::kIsExtendedId) extended = *flag;
        if (k == Key::kIsRemoteFrame) remote = *flag;
        if (k == Key::kIsErrorFrame) error = *flag;
        if (k == Key::kIsFd) fd = *flag;
        if (k == Key::kBitrateSwitch) brs = *flag;
        if (k == Key::kErrorStateIndicator) esi = *flag;
        break;
      }
      case Key::kUnknown:
        return MessageError(key.substr(0, 40), "is not a can.Message field");
    }
  }
  if (!r.at_end()) {
    return MessageError("", absl::StrCat(datagram.size() - r.position(), " trailing bytes"));
  }
  // python-can replaces the timestamp with its receive time; a paced channel reads it as the
  // frame's end on the wire (decision 805).
  if (timestamp_s != nullptr) *timestamp_s = timestamp;
  // can.Message._check, in its order.
  if (remote && error) return MessageError("is_remote_frame", "a frame cannot be remote and error");
  if (remote && fd) return MessageError("is_remote_frame", "CAN FD has no remote frames");
  if (arbitration_id < 0) return MessageError("arbitration_id", "negative");
  if (extended && arbitration_id > kCanExtendedIdMax) {
    return MessageError("arbitration_id",
                        absl::StrCat(arbitration_id, " exceeds 0x1FFFFFFF (29-bit)"));
  }
  if (!extended && arbitration_id > kCanStandardIdMax) {
    return MessageError("arbitration_id", absl::StrCat(arbitration_id, " exceeds 0x7FF (11-bit)"));
  }
  const int64_t length = has_dlc ? dlc : remote ? 0 : static_cast<int64_t>(data.size());
  if (length < 0) return MessageError("dlc", "negative");
  if (fd) {
    return absl::UnimplementedError("python-can message.is_fd: CAN FD frames are not supported");
  }
  if (length > kCanMaxDlc) return MessageError("dlc", absl::StrCat(length, " exceeds 8"));
  if (remote && !data.empty()) return MessageError("data", "remote frames carry no data");
  if (!remote && length != static_cast<int64_t>(data.size())) {
    return MessageError("dlc",
                        absl::StrCat(length, " differs from the ", data.size(), " data bytes"));
  }
  if (brs || esi) return MessageError("bitrate_switch", "only allowed for CAN FD frames");
  CanFrame frame;
  frame.id = static_cast<uint32_t>(arbitration_id);
  frame.extended = extended;
  frame.rtr = remote;
  frame.error = error;
  frame.dlc = static_cast<uint8_t>(length);
  std::copy(data.begin(), data.end(), frame.data.begin());
  return frame;
}

absl::StatusOr<std::unique_ptr<UdpMulticastChannel>> UdpMulticastChannel::Open(Options options) {
  const std::string where = absl::StrCat("udp:", options.group, ":", options.port);
  in_addr group{};
  if (::inet_pton(AF_INET, options.group.c_str(), &group) != 1) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": group '", options.group, "' is not an IPv4 address"));
  }
  if ((ntohl(group.s_addr) >> 28) != 0xE) {
    return absl::InvalidArgumentError(absl::StrCat(
        where, ": group '", options.group, "' is not an IPv4 multicast address (224.0.0.0/4)"));
  }
  if (options.port == 0) {
    return absl::InvalidArgumentError(absl::StrCat(where, ": port 0 is not a bus port (1..65535)"));
  }
  std::unique_ptr<UdpMulticastChannel> ch(new UdpMulticastChannel());
  ch->name_ = where;
  ch->trace_ = std::move(options.trace);
  auto fail = [&](std::string_view step, int err) {
    if (IsRouteError(err)) {
      return absl::UnavailableError(
          absl::StrCat(where, ": ", std::string(step), ": ", ErrnoText(err), ": ", kRouteHint));
    }
    if (err == EADDRINUSE || err == EACCES || err == EADDRNOTAVAIL) {
      return absl::UnavailableError(
          absl::StrCat(where, ": ", std::string(step), ": ", ErrnoText(err)));
    }
    return absl::InternalError(absl::StrCat(where, ": ", std::string(step), ": ", ErrnoText(err)));
  };

  // Receiver: SO_REUSEADDR so python-can and our processes share the port (python-can sets it
  // too); bound to the group address and IP_MULTICAST_ALL off so that another group on the
  // same port, or unicast to the port, is not mixed into this bus.
  ch->rx_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (ch->rx_fd_ < 0) return fail("socket", errno);
  const int one = 1, zero = 0;
  if (::setsockopt(ch->rx_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one)) != 0) {
    return fail("SO_REUSEADDR", errno);
  }
  if (::setsockopt(ch->rx_fd_, IPPROTO_IP, IP_MULTICAST_ALL, &zero, sizeof(zero)) != 0) {
    return fail("IP_MULTICAST_ALL", errno);
  }
  const int rcvbuf = 1 << 20;  // bursts of frames; the kernel caps it at net.core.rmem_max
  (void)::setsockopt(ch->rx_fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof(rcvbuf));
  sockaddr_in bind_addr{};
  bind_addr.sin_family = AF_INET;
  bind_addr.sin_addr = group;
  bind_addr.sin_port = htons(options.port);
  if (::bind(ch->rx_fd_, reinterpret_cast<const sockaddr*>(&bind_addr), sizeof(bind_addr)) != 0) {
    return fail("bind", errno);
  }
  // INADDR_ANY: the kernel picks the interface by route, as python-can does, so both end up
  // on the same interface and see each other's datagrams.
  ip_mreqn membership{};
  membership.imr_multiaddr = group;
  membership.imr_address.s_addr = htonl(INADDR_ANY);
  membership.imr_ifindex = 0;
  if (::setsockopt(ch->rx_fd_, IPPROTO_IP, IP_ADD_MEMBERSHIP, &membership, sizeof(membership)) !=
      0) {
    return fail("join group (IP_ADD_MEMBERSHIP)", errno);
  }

  // Sender: its own ephemeral port identifies our datagrams when the loop brings them back.
  ch->tx_fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (ch->tx_fd_ < 0) return fail("socket", errno);
  const int ttl = 1;  // python-can's hop_limit default: the bus stays on this link
  if (::setsockopt(ch->tx_fd_, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, sizeof(ttl)) != 0) {
    return fail("IP_MULTICAST_TTL", errno);
  }
  if (::setsockopt(ch->tx_fd_, IPPROTO_IP, IP_MULTICAST_LOOP, &one, sizeof(one)) != 0) {
    return fail("IP_MULTICAST_LOOP", errno);
  }
  sockaddr_in to = bind_addr;
  if (::connect(ch->tx_fd_, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) != 0) {
    return fail("connect (route to the group)", errno);
  }
  sockaddr_in local{};
  socklen_t len = sizeof(local);
  if (::getsockname(ch->tx_fd_, reinterpret_cast<sockaddr*>(&local), &len) != 0) {
    return fail("getsockname", errno);
  }
  ch->sender_ipv4_ = ntohl(local.sin_addr.s_addr);
  ch->sender_port_ = ntohs(local.sin_port);

  ch->wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (ch->wake_fd_ < 0) return fail("eventfd", errno);
  if (options.bitrate != 0) {
    auto pacer = CanTxPacer::Create(options.bitrate);
    if (!pacer.ok())
      return absl::Status(pacer.status().code(),
                          absl::StrCat(where, ": ", pacer.status().message()));
    ch->pacer_ = *std::move(pacer);
    auto timer = MonotonicTimer::Create();
    if (!timer.ok()) return timer.status();
    ch->rx_timer_.emplace(*std::move(timer));
  }
  log::Info("can_open", log::Fields()
                            .Add("bus", ch->name_)
                            .Add("backend", "udp_multicast")
                            .Add("sender_port", ch->sender_port_)
                            .Add("bitrate", static_cast<int64_t>(options.bitrate)));
  return ch;
}

UdpMulticastChannel::~UdpMulticastChannel() {
  for (int fd : {rx_fd_, tx_fd_, wake_fd_}) {
    if (fd >= 0) ::close(fd);
  }
}

absl::Status UdpMulticastChannel::Send(const CanFrame& frame) {
  if (absl::Status s = ValidateCanFrame(frame); !s.ok()) return s;
  if (!pacer_) return SendDatagram(frame, WallSeconds());
  // Read the clock before queueing behind other senders: a frame queued while the previous
  // one is on the wire starts at its end. The datagram leaves when the frame starts and carries
  // its end, when paced receivers hand it over (decision 805): the UDP hop hides in the bit time.
  const auto queued = SteadyTime::now();
  std::lock_guard lock(pace_mu_);
  const CanTxPacer::Slot slot = pacer_->Transmit(frame, queued);
  return SendDatagram(
      frame, WallSeconds() + std::chrono::duration<double>(slot.end - SteadyTime::now()).count());
}

absl::Status UdpMulticastChannel::SendDatagram(const CanFrame& frame, double timestamp_s) {
  const std::vector<uint8_t> bytes = EncodePythonCanMessage(frame, timestamp_s);
  // A full send buffer (a burst faster than the interface queue drains) is waited out for
  // up to kSendWait, as a CAN controller's transmit queue would; python-can blocks outright.
  const auto give_up = SteadyTime::now() + kSendWait;
  for (;;) {
    const ssize_t n = ::send(tx_fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
    if (n >= 0) break;
    if (errno == EINTR) continue;
    const int err = errno;
    if ((err == EAGAIN || err == EWOULDBLOCK || err == ENOBUFS) && SteadyTime::now() < give_up) {
      pollfd pfd{tx_fd_, POLLOUT, 0};
      if (::poll(&pfd, 1, PollMillis(give_up - SteadyTime::now())) >= 0 || errno == EINTR) continue;
    }
    tx_errors_.fetch_add(1, std::memory_order_relaxed);
    if (IsRouteError(err)) {
      state_.store(CanBusState::kDown, std::memory_order_release);
      return absl::UnavailableError(absl::StrCat(name_, ": send ", FormatCanFrame(frame), ": ",
                                                 ErrnoText(err), ": ", kRouteHint));
    }
    return absl::UnavailableError(
        absl::StrCat(name_, ": send ", FormatCanFrame(frame), ": ", ErrnoText(err)));
  }
  state_.store(CanBusState::kActive, std::memory_order_release);
  tx_.fetch_add(1, std::memory_order_relaxed);
  if (trace_) trace_->Record(name_, frame, CanDirection::kTx);
  return absl::OkStatus();
}

bool UdpMulticastChannel::Accepts(const CanFrame& frame) const {
  std::lock_guard lock(filters_mu_);
  if (filters_.empty()) return true;
  return std::any_of(filters_.begin(), filters_.end(),
                     [&](const CanFilter& f) { return f.Matches(frame); });
}

std::optional<CanFrame> UdpMulticastChannel::PopDueLocked(SteadyTime::time_point now) {
  if (held_.empty() || held_.front().at > now) return std::nullopt;
  const CanFrame frame = held_.front().frame;
  held_.pop_front();
  return frame;
}

void UdpMulticastChannel::HoldLocked(const CanFrame& frame, double timestamp_s) {
  // Due at the announced end of the frame, at most one longest frame from now: a sender paced at
  // a slower rate or with another clock must not stall this node (decision 805).
  const auto now = SteadyTime::now();
  const double ahead_s = timestamp_s - WallSeconds();
  const auto ahead = ahead_s <= 0 ? SteadyTime::duration::zero()
                                  : std::min(std::chrono::duration_cast<SteadyTime::duration>(
                                                 std::chrono::duration<double>(ahead_s)),
                                             pacer_->longest_frame());
  const HeldFrame held{now + ahead, frame};
  // Frames of several senders interleave: keep end-of-frame order (stable for equal ends).
  const auto pos =
      std::upper_bound(held_.begin(), held_.end(), held.at,
                       [](SteadyTime::time_point at, const HeldFrame& h) { return at < h.at; });
  held_.insert(pos, held);
}

absl::StatusOr<std::optional<CanFrame>> UdpMulticastChannel::Receive(
    std::chrono::nanoseconds timeout) {
  const auto wait = std::clamp(timeout, std::chrono::nanoseconds::zero(),
                               std::chrono::nanoseconds(std::chrono::hours(24 * 365)));
  const auto deadline = SteadyTime::now() + std::chrono::duration_cast<SteadyTime::duration>(wait);
  auto deliver = [&](const CanFrame& frame) {
    rx_.fetch_add(1, std::memory_order_relaxed);
    if (trace_) trace_->Record(name_, frame, CanDirection::kRx);
    return std::optional<CanFrame>(frame);
  };
  for (;;) {
    std::array<pollfd, 3> fds{{{rx_fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}, {-1, POLLIN, 0}}};
    auto until = deadline;
    if (pacer_) {
      std::unique_lock lock(held_mu_);
      if (auto due = PopDueLocked(SteadyTime::now())) return deliver(*due);
      if (!held_.empty()) {
        const auto at = held_.front().at;
        if (at - SteadyTime::now() <= kHoldSpin) {
          // The last stretch is waited out on the CPU: a timer wake-up on this VM comes 45 us
          // (median) to 85 us (p90) late, as long as a 1 Mbit/s frame's fifth (decision 805).
          lock.unlock();
          while (SteadyTime::now() < at) CpuRelax();
          continue;
        }
        // The timerfd wakes just before the held frame's end, without poll's millisecond
        // rounding and timer slack.
        rx_timer_->Arm(at - kHoldSpin);
        fds[2].fd = rx_timer_->fd();
        until = std::min(until, at);
      }
    }
    const int ready = ::poll(fds.data(), fds.size(), PollMillis(until - SteadyTime::now()));
    if (ready < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      rx_errors_.fetch_add(1, std::memory_order_relaxed);
      return absl::InternalError(absl::StrCat(name_, ": poll: ", ErrnoText(err)));
    }
    if (fds[1].revents & POLLIN) {
      uint64_t value = 0;
      // Consume the wake-up; a concurrent receiver may have taken it first (EAGAIN).
      if (::read(wake_fd_, &value, sizeof(value)) == sizeof(value)) return std::nullopt;
    }
    if (fds[0].revents & (POLLIN | POLLERR)) {
      // Drain what is queued; own, filtered and malformed datagrams do not end the wait.
      for (;;) {
        std::array<uint8_t, 4096> buffer;  // python-can's max_buffer; our datagrams are ~150 B
        sockaddr_in from{};
        socklen_t from_len = sizeof(from);
        const ssize_t n = ::recvfrom(rx_fd_, buffer.data(), buffer.size(), MSG_TRUNC,
                                     reinterpret_cast<sockaddr*>(&from), &from_len);
        if (n < 0) {
          const int err = errno;
          if (err == EAGAIN || err == EWOULDBLOCK) break;
          if (err == EINTR) continue;
          rx_errors_.fetch_add(1, std::memory_order_relaxed);
          if (err == ECONNREFUSED) continue;  // ICMP for an earlier datagram: not ours to fix
          return absl::InternalError(absl::StrCat(name_, ": recvfrom: ", ErrnoText(err)));
        }
        const uint32_t src_ip = ntohl(from.sin_addr.s_addr);
        // Our own datagram looped back: same sender port from our address (0.0.0.0 shows up
        // when the group is routed over lo without a source address).
        if (ntohs(from.sin_port) == sender_port_ && (src_ip == sender_ipv4_ || src_ip == 0)) {
          continue;
        }
        if (static_cast<size_t>(n) > buffer.size()) {
          dropped_malformed_.fetch_add(1, std::memory_order_relaxed);
          log::Debug("can_drop",
                     log::Fields().Add("bus", name_).Add("reason", "oversize").Add("bytes", n));
          continue;
        }
        double timestamp_s = 0;
        auto frame = DecodePythonCanMessage(
            std::span<const uint8_t>(buffer.data(), static_cast<size_t>(n)), &timestamp_s);
        if (!frame.ok()) {
          dropped_malformed_.fetch_add(1, std::memory_order_relaxed);
          log::Debug("can_drop",
                     log::Fields().Add("bus", name_).Add("reason", frame.status().message()));
          continue;
        }
        if (frame->error) {
          error_frames_.fetch_add(1, std::memory_order_relaxed);
          if (trace_) trace_->Record(name_, *frame, CanDirection::kRx);
          continue;
        }
        if (!Accepts(*frame)) continue;
        if (!pacer_) return deliver(*frame);
        std::lock_guard lock(held_mu_);
        HoldLocked(*frame, timestamp_s);
        if (held_.front().at <= SteadyTime::now()) break;  // one is due: hand it over first
      }
    }
    if (SteadyTime::now() >= deadline) {
      if (!pacer_) return std::nullopt;
      std::lock_guard lock(held_mu_);
      if (auto due = PopDueLocked(SteadyTime::now())) return deliver(*due);
      return std::nullopt;
    }
  }
}

void UdpMulticastChannel::Wake() {
  const uint64_t one = 1;
  // EAGAIN only when the counter would overflow: a wake-up is pending anyway.
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

absl::Status UdpMulticastChannel::SetFilters(std::span<const CanFilter> filters) {
  if (absl::Status s = ValidateCanFilters(filters); !s.ok()) return s;
  std::lock_guard lock(filters_mu_);
  filters_.assign(filters.begin(), filters.end());
  return absl::OkStatus();
}

CanCounters UdpMulticastChannel::counters() const {
  CanCounters c;
  c.tx = tx_.load(std::memory_order_relaxed);
  c.rx = rx_.load(std::memory_order_relaxed);
  c.tx_errors = tx_errors_.load(std::memory_order_relaxed);
  c.rx_errors = rx_errors_.load(std::memory_order_relaxed);
  c.error_frames = error_frames_.load(std::memory_order_relaxed);
  c.dropped_malformed = dropped_malformed_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace drivegw::transport
