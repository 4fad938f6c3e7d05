// Classic CAN frame lengths with exact bit stuffing, and the per-node transmit pacer of the
// user-space bus (docs/decisions/805-udp-bus-bit-timing.md).
#include "adapters/transport/can_bit_timing.h"

#include <poll.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <thread>
#include <utility>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {
namespace {

// CRC delimiter (1), ACK slot (1), ACK delimiter (1), end of frame (7) and intermission (3):
// fixed form, never stuffed (CAN 2.0 §5: stuffing ends with the CRC sequence).
constexpr uint32_t kUnstuffedTailBits = 13;
// CAN 2.0 §3.1.1 CRC field: x^15 + x^14 + x^10 + x^8 + x^7 + x^4 + x^3 + 1.
constexpr uint16_t kCrc15Polynomial = 0x4599;

// Walks the stuffed part of a frame bit by bit: CRC-15 over the bits, and the stuff bits a
// transmitter inserts after five equal bits in a row (the stuff bit itself starts the next run).
class StuffCounter {
 public:
  void Bits(uint32_t value, int count) {
    for (int i = count - 1; i >= 0; --i) Bit(((value >> i) & 1u) != 0);
  }
  // The CRC sequence is stuffed but not part of its own CRC.
  void AppendCrc() {
    const uint16_t crc = crc_;
    for (int i = 14; i >= 0; --i) Stuff(((crc >> i) & 1u) != 0);
  }
  uint32_t bits() const { return bits_; }
  uint32_t stuff_bits() const { return stuff_bits_; }

 private:
  void Bit(bool bit) {
    const bool next = bit != (((crc_ >> 14) & 1u) != 0);
    crc_ = static_cast<uint16_t>((crc_ << 1) & 0x7FFF);
    if (next) crc_ ^= kCrc15Polynomial;
    Stuff(bit);
  }
  void Stuff(bool bit) {
    ++bits_;
    if (run_ > 0 && bit == last_) {
      ++run_;
    } else {
      last_ = bit;
      run_ = 1;
    }
    if (run_ == 5) {  // the complement follows and counts as the first bit of a new run
      ++stuff_bits_;
      last_ = !bit;
      run_ = 1;
    }
  }

  uint16_t crc_ = 0;
  uint32_t bits_ = 0;
  uint32_t stuff_bits_ = 0;
  bool last_ = false;
  int run_ = 0;
};

// Bits from SOF to the end of the CRC sequence, without stuffing: 34 base, 54 extended, plus data.
uint32_t StuffableBits(uint8_t dlc, bool extended, bool rtr) {
  const uint32_t data = rtr ? 0 : 8u * std::min<uint32_t>(dlc, 8);
  return (extended ? 54u : 34u) + data;
}

}  // namespace

bool IsSupportedCanBitrate(uint32_t bitrate) {
  return std::find(std::begin(kCanBitrates), std::end(kCanBitrates), bitrate) !=
         std::end(kCanBitrates);
}

uint32_t CanFrameBits(const CanFrame& frame) {
  StuffCounter s;
  s.Bits(0, 1);  // SOF, dominant
  const uint8_t dlc = frame.dlc > 8 ? 8 : frame.dlc;
  if (frame.extended) {
    // ISO 11898-1 extended format: base id (11 most significant bits), SRR and IDE recessive,
    // the 18-bit id extension, RTR, r1, r0.
    s.Bits((frame.id >> 18) & 0x7FF, 11);
    s.Bits(1, 1);  // SRR
    s.Bits(1, 1);  // IDE
    s.Bits(frame.id & 0x3FFFF, 18);
    s.Bits(frame.rtr ? 1 : 0, 1);
    s.Bits(0, 2);  // r1, r0 dominant
  } else {
    s.Bits(frame.id & 0x7FF, 11);
    s.Bits(frame.rtr ? 1 : 0, 1);
    s.Bits(0, 2);  // IDE dominant (base format), r0
  }
  s.Bits(dlc, 4);
  if (!frame.rtr) {
    for (uint8_t i = 0; i < dlc; ++i) s.Bits(frame.data[i], 8);
  }
  s.AppendCrc();
  return s.bits() + s.stuff_bits() + kUnstuffedTailBits;
}

uint32_t CanNominalFrameBits(uint8_t dlc, bool extended, bool rtr) {
  return StuffableBits(dlc, extended, rtr) + kUnstuffedTailBits;
}

uint32_t CanWorstCaseFrameBits(uint8_t dlc, bool extended, bool rtr) {
  const uint32_t stuffable = StuffableBits(dlc, extended, rtr);
  return stuffable + kUnstuffedTailBits + (stuffable - 1) / 4;
}

std::chrono::nanoseconds CanBitTime(uint32_t bits, uint32_t bitrate) {
  if (bitrate == 0) return std::chrono::nanoseconds::zero();
  return std::chrono::nanoseconds((static_cast<uint64_t>(bits) * 1'000'000'000ull + bitrate / 2) /
                                  bitrate);
}

absl::StatusOr<MonotonicTimer> MonotonicTimer::Create() {
  const int fd = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  if (fd < 0) {
    return absl::InternalError(absl::StrCat("can timer: timerfd_create: ", std::strerror(errno)));
  }
  return MonotonicTimer(fd);
}

MonotonicTimer& MonotonicTimer::operator=(MonotonicTimer&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

MonotonicTimer::~MonotonicTimer() {
  if (fd_ >= 0) ::close(fd_);
}

void MonotonicTimer::Arm(SteadyTime::time_point t) {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch());
  itimerspec spec{};
  spec.it_value.tv_sec = static_cast<time_t>(ns.count() / 1'000'000'000);
  spec.it_value.tv_nsec = static_cast<long>(ns.count() % 1'000'000'000);
  if (spec.it_value.tv_sec <= 0 && spec.it_value.tv_nsec <= 0)
    spec.it_value.tv_nsec = 1;  // 0 disarms
  (void)::timerfd_settime(fd_, TFD_TIMER_ABSTIME, &spec, nullptr);
}

void MonotonicTimer::Disarm() {
  const itimerspec off{};
  (void)::timerfd_settime(fd_, 0, &off, nullptr);
  uint64_t expirations = 0;
  (void)::read(fd_, &expirations, sizeof(expirations));  // non-blocking: clears a pending expiry
}

void MonotonicTimer::SleepUntil(SteadyTime::time_point t) {
  if (SteadyTime::now() >= t) return;
  Arm(t);
  pollfd pfd{fd_, POLLIN, 0};
  while (SteadyTime::now() < t) {
    if (::poll(&pfd, 1, -1) < 0 && errno != EINTR) {
      std::this_thread::sleep_until(t);  // still absolute; only the timer slack comes back
      break;
    }
    if (pfd.revents & POLLIN) break;
  }
  Disarm();
}

CanTxPacer::CanTxPacer(uint32_t bitrate, MonotonicTimer timer)
    : bitrate_(bitrate),
      timer_(std::move(timer)),
      longest_frame_(std::chrono::duration_cast<SteadyTime::duration>(
          CanBitTime(CanWorstCaseFrameBits(8, /*extended=*/true), bitrate))) {}

absl::StatusOr<std::unique_ptr<CanTxPacer>> CanTxPacer::Create(uint32_t bitrate) {
  if (!IsSupportedCanBitrate(bitrate)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "can bitrate: ", bitrate, " is not one of 125000, 250000, 500000, 1000000 bit/s"));
  }
  auto timer = MonotonicTimer::Create();
  if (!timer.ok()) return timer.status();
  return std::unique_ptr<CanTxPacer>(new CanTxPacer(bitrate, *std::move(timer)));
}

CanTxPacer::Slot CanTxPacer::Transmit(const CanFrame& frame, SteadyTime::time_point queued) {
  // The frame starts when both it is queued and the node's previous frame has ended; measuring
  // from the schedule (free_at_), not from when this thread woke, keeps bursts drift-free.
  Slot slot;
  slot.start = std::max(queued, free_at_);
  slot.end = slot.start + std::chrono::duration_cast<SteadyTime::duration>(
                              CanBitTime(CanFrameBits(frame), bitrate_));
  free_at_ = slot.end;
  timer_.SleepUntil(slot.start);
  return slot;
}

}  // namespace drivegw::transport
