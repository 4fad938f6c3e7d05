// SocketCanChannel: PF_CAN/CAN_RAW (kernel Documentation/networking/can.rst §4.1), error
// frames per linux/can/error.h, poll() on the socket plus an eventfd for Wake.
#include "adapters/transport/socketcan_channel.h"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <utility>

#include "absl/strings/str_cat.h"
#include "adapters/core/log.h"

namespace drivegw::transport {
namespace {

using SteadyTime = std::chrono::steady_clock;

// "No such device (ENODEV)": the text for people, the name for searching.
std::string ErrnoText(int err) {
  const char* name = ::strerrorname_np(err);
  return absl::StrCat(std::strerror(err), " (",
                      name ? std::string(name) : absl::StrCat("errno ", err), ")");
}

int PollMillis(SteadyTime::duration remaining) {
  if (remaining <= SteadyTime::duration::zero()) return 0;
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(remaining).count();
  return ms > 1'000'000'000 ? 1'000'000'000 : static_cast<int>(ms);
}

bool IsFault(CanBusState s) { return s == CanBusState::kBusOff || s == CanBusState::kDown; }

}  // namespace

CanBusState NextCanBusState(CanBusState current, const CanFrame& error_frame) {
  if (!error_frame.error) return current;
  const uint32_t cls = error_frame.id;
  if (cls & CAN_ERR_BUSOFF) return CanBusState::kBusOff;
  if (cls & CAN_ERR_RESTARTED) return CanBusState::kActive;
  // Only a restart ends bus-off (ISO 11898-1 §12.1.4.2); kDown ends by recovery.
  if (IsFault(current)) return current;
  if (cls & CAN_ERR_CRTL) {
    const uint8_t d1 = error_frame.data[1];
    if (d1 & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) return CanBusState::kPassive;
    if (d1 & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) return CanBusState::kWarning;
    if (d1 & CAN_ERR_CRTL_ACTIVE) return CanBusState::kActive;
  }
  return current;
}

absl::StatusOr<std::unique_ptr<SocketCanChannel>> SocketCanChannel::Open(Options options) {
  const std::string where = absl::StrCat("can.socketcan.interface '", options.interface, "'");
  if (options.interface.empty() || options.interface.size() >= IFNAMSIZ) {
    return absl::InvalidArgumentError(
        absl::StrCat(where, ": an interface name has 1..", IFNAMSIZ - 1, " characters"));
  }
  std::unique_ptr<SocketCanChannel> ch(new SocketCanChannel(std::move(options)));
  auto fd = ch->OpenSocket();
  if (!fd.ok()) return fd.status();
  ch->fd_ = *fd;
  ch->wake_fd_ = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (ch->wake_fd_ < 0) {
    return absl::InternalError(absl::StrCat(where, ": eventfd: ", ErrnoText(errno)));
  }
  const auto flags = ch->InterfaceFlags();
  if (!flags || !(*flags & IFF_UP)) {
    ch->EnterFault(CanBusState::kDown, "interface is down");
  }
  log::Info("can_open", log::Fields()
                            .Add("bus", ch->name())
                            .Add("backend", "socketcan")
                            .Add("state", CanBusStateName(ch->state())));
  return ch;
}

absl::StatusOr<int> SocketCanChannel::OpenSocket() const {
  const std::string where = absl::StrCat("can.socketcan.interface '", options_.interface, "'");
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int err = errno;
    if (err == EAFNOSUPPORT) {
      return absl::UnavailableError(
          absl::StrCat(where,
                       ": this kernel has no SocketCAN (EAFNOSUPPORT); load the can and can-raw "
                       "modules or use the udp bus (can: {udp: {...}})"));
    }
    if (err == EPROTONOSUPPORT) {
      return absl::UnavailableError(absl::StrCat(
          where, ": this kernel has SocketCAN but no CAN_RAW (EPROTONOSUPPORT); modprobe can-raw"));
    }
    return absl::UnavailableError(absl::StrCat(where, ": socket(PF_CAN): ", ErrnoText(err)));
  }
  auto fail = [&](std::string_view step, int err) {
    ::close(fd);
    return absl::UnavailableError(
        absl::StrCat(where, ": ", std::string(step), ": ", ErrnoText(err)));
  };
  const unsigned index = ::if_nametoindex(options_.interface.c_str());
  if (index == 0) {
    const int err = errno;
    ::close(fd);
    if (err == ENODEV || err == ENXIO) {
      return absl::UnavailableError(absl::StrCat(where, ": no such interface (ENODEV)"));
    }
    return absl::UnavailableError(absl::StrCat(where, ": if_nametoindex: ", ErrnoText(err)));
  }
  // Error frames that move the state (NextCanBusState) plus TX time-outs, counted.
  const can_err_mask_t err_mask =
      CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_RESTARTED | CAN_ERR_TX_TIMEOUT;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0) {
    return fail("CAN_RAW_ERR_FILTER", errno);
  }
  std::vector<CanFilter> filters;
  {
    std::lock_guard lock(filters_mu_);
    filters = filters_;
  }
  if (absl::Status s = ApplyFilters(fd, filters); !s.ok()) {
    ::close(fd);
    return s;
  }
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    return fail("bind", errno);
  }
  return fd;
}

absl::Status SocketCanChannel::ApplyFilters(int fd, const std::vector<CanFilter>& filters) const {
  std::vector<can_filter> raw;
  if (filters.empty()) {
    raw.push_back(can_filter{0, 0});  // CAN_RAW's default: one filter that passes everything
  }
  for (const CanFilter& f : filters) {
    // CAN_EFF_FLAG in the mask makes the kernel compare the frame format too (can.rst §4.1.1);
    // RTR is left out of the mask, so data and remote frames of a matching id both pass.
    can_filter k{};
    k.can_id = f.extended ? ((f.id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (f.id & CAN_SFF_MASK);
    k.can_mask = (f.mask & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK)) | CAN_EFF_FLAG;
    raw.push_back(k);
  }
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, raw.data(),
                   static_cast<socklen_t>(raw.size() * sizeof(can_filter))) != 0) {
    return absl::UnavailableError(absl::StrCat("can.socketcan.interface '", options_.interface,
                                               "': CAN_RAW_FILTER: ", ErrnoText(errno)));
  }
  return absl::OkStatus();
}

std::optional<unsigned> SocketCanChannel::InterfaceFlags() const {
  // Any socket family answers SIOCGIFFLAGS for any interface; AF_INET always exists.
  const int probe = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (probe < 0) return std::nullopt;
  ifreq req{};
  std::strncpy(req.ifr_name, options_.interface.c_str(), IFNAMSIZ - 1);
  const int rc = ::ioctl(probe, SIOCGIFFLAGS, &req);
  ::close(probe);
  if (rc != 0) return std::nullopt;
  return static_cast<unsigned>(static_cast<unsigned short>(req.ifr_flags));
}

SocketCanChannel::~SocketCanChannel() {
  if (fd_ >= 0) ::close(fd_);
  if (wake_fd_ >= 0) ::close(wake_fd_);
}

void SocketCanChannel::EnterFault(CanBusState state, std::string_view why) {
  const CanBusState before = state_.exchange(state, std::memory_order_acq_rel);
  if (state == CanBusState::kBusOff && before != CanBusState::kBusOff) {
    bus_off_events_.fetch_add(1, std::memory_order_relaxed);
  }
  if (IsFault(before)) return;  // already scheduled
  std::chrono::milliseconds delay;
  {
    std::lock_guard lock(recovery_mu_);
    delay = backoff_.Next();
    next_recovery_ = SteadyTime::now() + delay;
  }
  log::Warn("can_fault", log::Fields()
                             .Add("bus", name())
                             .Add("state", CanBusStateName(state))
                             .Add("why", why)
                             .Add("retry_ms", delay.count()));
}

void SocketCanChannel::TryRecover() {
  std::unique_lock recovery(recovery_mu_, std::try_to_lock);
  if (!recovery.owns_lock()) return;  // another thread is at it
  const auto now = SteadyTime::now();
  if (now < next_recovery_ || !IsFault(state())) return;
  const auto flags = InterfaceFlags();
  auto reschedule = [&](CanBusState s, const std::string& why) {
    state_.store(s, std::memory_order_release);
    const auto delay = backoff_.Next();
    next_recovery_ = now + delay;
    log::Debug("can_recovery", log::Fields()
                                   .Add("bus", name())
                                   .Add("state", CanBusStateName(s))
                                   .Add("why", why)
                                   .Add("retry_ms", delay.count()));
  };
  if (!flags) return reschedule(CanBusState::kDown, "interface gone");
  // Reopen: after a re-plug the interface has a new index and the old socket is unbound.
  auto fd = OpenSocket();
  if (!fd.ok()) return reschedule(CanBusState::kDown, std::string(fd.status().message()));
  {
    std::unique_lock lock(fd_mu_);
    if (fd_ >= 0) ::close(fd_);
    fd_ = *fd;
  }
  // can-dev turns the carrier off while the controller is bus-off (can_bus_off), so
  // IFF_RUNNING tells a restarted controller from one still off the bus.
  if (!(*flags & IFF_UP)) return reschedule(CanBusState::kDown, "interface is down");
  if (!(*flags & IFF_RUNNING)) {
    return reschedule(state() == CanBusState::kBusOff ? CanBusState::kBusOff : CanBusState::kDown,
                      "no carrier");
  }
  backoff_.Reset();
  state_.store(CanBusState::kActive, std::memory_order_release);
  log::Warn("can_recovered", log::Fields().Add("bus", name()).Add("state", "active"));
}

void SocketCanChannel::OnErrorFrame(const CanFrame& frame) {
  error_frames_.fetch_add(1, std::memory_order_relaxed);
  if (options_.trace) options_.trace->Record(name(), frame, CanDirection::kRx);
  const CanBusState before = state();
  const CanBusState after = NextCanBusState(before, frame);
  if (after == before) return;
  if (after == CanBusState::kBusOff) {
    EnterFault(CanBusState::kBusOff, "CAN_ERR_BUSOFF");
    return;
  }
  state_.store(after, std::memory_order_release);
  if (after == CanBusState::kActive) {
    std::lock_guard lock(recovery_mu_);
    backoff_.Reset();  // the kernel restarted the controller (restart-ms)
  }
  log::Warn("can_state", log::Fields()
                             .Add("bus", name())
                             .Add("from", CanBusStateName(before))
                             .Add("to", CanBusStateName(after)));
}

absl::Status SocketCanChannel::Send(const CanFrame& frame) {
  if (absl::Status s = ValidateCanFrame(frame); !s.ok()) return s;
  const CanBusState st = state();
  if (IsFault(st)) {
    tx_errors_.fetch_add(1, std::memory_order_relaxed);
    return absl::UnavailableError(absl::StrCat(name(), ": send ", FormatCanFrame(frame),
                                               ": bus is ", CanBusStateName(st), ", recovering"));
  }
  can_frame raw{};
  raw.can_id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0) | (frame.rtr ? CAN_RTR_FLAG : 0);
  raw.len = frame.dlc;
  std::copy_n(frame.data.begin(), frame.rtr ? 0 : frame.dlc, raw.data);
  int err = 0;
  {
    std::shared_lock lock(fd_mu_);
    for (;;) {
      const ssize_t n = ::write(fd_, &raw, sizeof(raw));
      if (n == static_cast<ssize_t>(sizeof(raw))) break;
      if (n < 0 && errno == EINTR) continue;
      err = n < 0 ? errno : EIO;
      break;
    }
  }
  if (err == 0) {
    tx_.fetch_add(1, std::memory_order_relaxed);
    if (options_.trace) options_.trace->Record(name(), frame, CanDirection::kTx);
    return absl::OkStatus();
  }
  tx_errors_.fetch_add(1, std::memory_order_relaxed);
  if (err == ENETDOWN || err == ENODEV || err == ENXIO) {
    EnterFault(CanBusState::kDown, ErrnoText(err));
  }
  // ENOBUFS/EAGAIN: the driver's queue is full, typically no other node ACKs (can.rst §3.4).
  return absl::UnavailableError(
      absl::StrCat(name(), ": send ", FormatCanFrame(frame), ": ", ErrnoText(err)));
}

absl::StatusOr<std::optional<CanFrame>> SocketCanChannel::Receive(
    std::chrono::nanoseconds timeout) {
  const auto wait = std::clamp(timeout, std::chrono::nanoseconds::zero(),
                               std::chrono::nanoseconds(std::chrono::hours(24 * 365)));
  const auto deadline = SteadyTime::now() + std::chrono::duration_cast<SteadyTime::duration>(wait);
  for (;;) {
    auto until = deadline;
    if (IsFault(state())) {
      TryRecover();
      if (IsFault(state())) {
        // Wake for the next attempt, at least 1 ms ahead: never a busy loop, even when
        // another thread holds the recovery.
        const auto now = SteadyTime::now();
        std::lock_guard lock(recovery_mu_);
        until = std::min(deadline, std::max(next_recovery_, now + std::chrono::milliseconds(1)));
      }
    }
    std::optional<CanFrame> got;
    {
      std::shared_lock lock(fd_mu_);
      std::array<pollfd, 2> fds{{{fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}}};
      const int ready = ::poll(fds.data(), fds.size(), PollMillis(until - SteadyTime::now()));
      if (ready < 0) {
        if (errno == EINTR) continue;
        const int err = errno;
        rx_errors_.fetch_add(1, std::memory_order_relaxed);
        return absl::InternalError(absl::StrCat(name(), ": poll: ", ErrnoText(err)));
      }
      if (fds[1].revents & POLLIN) {
        uint64_t value = 0;
        if (::read(wake_fd_, &value, sizeof(value)) == sizeof(value)) return std::nullopt;
      }
      if (fds[0].revents & (POLLIN | POLLERR)) {
        can_frame raw{};
        const ssize_t n = ::read(fd_, &raw, sizeof(raw));
        if (n < 0) {
          const int err = errno;
          if (err == ENETDOWN || err == ENODEV || err == ENXIO) {
            lock.unlock();
            EnterFault(CanBusState::kDown, ErrnoText(err));
            continue;
          }
          if (err != EAGAIN && err != EWOULDBLOCK && err != EINTR) {
            rx_errors_.fetch_add(1, std::memory_order_relaxed);
            return absl::InternalError(absl::StrCat(name(), ": read: ", ErrnoText(err)));
          }
        } else if (n != static_cast<ssize_t>(sizeof(raw)) || raw.len > CAN_MAX_DLEN) {
          dropped_malformed_.fetch_add(1, std::memory_order_relaxed);
        } else {
          CanFrame f;
          f.error = (raw.can_id & CAN_ERR_FLAG) != 0;
          f.extended = f.error || (raw.can_id & CAN_EFF_FLAG) != 0;
          f.rtr = !f.error && (raw.can_id & CAN_RTR_FLAG) != 0;
          f.id = raw.can_id & (f.error ? CAN_ERR_MASK : f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
          f.dlc = raw.len;
          std::copy_n(raw.data, f.rtr ? 0 : raw.len, f.data.begin());
          got = f;
        }
      }
    }
    if (got) {
      if (got->error) {
        OnErrorFrame(*got);
      } else {
        if (state() == CanBusState::kDown) {  // frames arrive: the interface carries again
          std::lock_guard lock(recovery_mu_);
          backoff_.Reset();
          state_.store(CanBusState::kActive, std::memory_order_release);
        }
        rx_.fetch_add(1, std::memory_order_relaxed);
        if (options_.trace) options_.trace->Record(name(), *got, CanDirection::kRx);
        return got;
      }
    }
    if (SteadyTime::now() >= deadline) return std::nullopt;
  }
}

void SocketCanChannel::Wake() {
  const uint64_t one = 1;
  [[maybe_unused]] const ssize_t n = ::write(wake_fd_, &one, sizeof(one));
}

absl::Status SocketCanChannel::SetFilters(std::span<const CanFilter> filters) {
  if (absl::Status s = ValidateCanFilters(filters); !s.ok()) return s;
  std::vector<CanFilter> copy(filters.begin(), filters.end());
  // Lock order filters_mu_ -> fd_mu_; OpenSocket (recovery) takes filters_mu_ alone.
  std::lock_guard filters_lock(filters_mu_);
  {
    std::shared_lock fd_lock(fd_mu_);
    if (absl::Status s = ApplyFilters(fd_, copy); !s.ok()) return s;
  }
  filters_ = std::move(copy);
  return absl::OkStatus();
}

CanCounters SocketCanChannel::counters() const {
  CanCounters c;
  c.tx = tx_.load(std::memory_order_relaxed);
  c.rx = rx_.load(std::memory_order_relaxed);
  c.tx_errors = tx_errors_.load(std::memory_order_relaxed);
  c.rx_errors = rx_errors_.load(std::memory_order_relaxed);
  c.error_frames = error_frames_.load(std::memory_order_relaxed);
  c.bus_off_events = bus_off_events_.load(std::memory_order_relaxed);
  c.dropped_malformed = dropped_malformed_.load(std::memory_order_relaxed);
  return c;
}

}  // namespace drivegw::transport
