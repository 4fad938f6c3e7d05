// RAII termios serial port (raw 8N1, poll() reads with deadlines, RS-485 turnaround, break, wake).
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

struct SerialConfig {
  enum class Duplex {
    kFull,       // RS-232: point to point, both directions at once (trinamic-sixpack.md §2.1)
    kHalfRs485,  // RS-485: one transmitter at a time on a 2-wire multi-drop bus (§2.1, L273)
  };

  std::string device;  // e.g. /dev/ttyUSB0, or a pty slave path / symlink in tests
  // One of the termios Bxxx rates, kSupportedBauds. The PACK's default is 19200 (§2.1).
  int baud = 9600;
  Duplex duplex = Duplex::kFull;
  // RS-485 only: the controller's transmitter switchover delay ($40 P2/P3, default 6 ms, §2.5).
  // The host waits this long after its last byte before it may expect/allow traffic (Write
  // returns only then), and never transmits while a reply may be coming: after the last byte
  // received it again waits this long (the PACK's line-release guard, G-04 [P]) before Write
  // puts anything on the line. Ignored for kFull.
  std::chrono::microseconds turnaround{0};
};

// The termios speeds SerialPort accepts (Bxxx constants of <termios.h>, 1200 ... 921600).
inline constexpr int kSupportedBauds[] = {1200,  1800,   2400,   4800,   9600,   19200,  38400,
                                          57600, 115200, 230400, 460800, 500000, 576000, 921600};

// InvalidArgument "serial.baud: 12345 is not a supported rate (1200, ..., 921600)" unless `baud`
// is in kSupportedBauds.
absl::Status ValidateBaud(int baud);
// InvalidArgument naming the field ("serial.device", "serial.baud", "serial.turnaround").
absl::Status ValidateSerialConfig(const SerialConfig& config);

// ReadExactly reports what arrived before a time-out or Wake() as a payload on the error status
// (StatusOr cannot carry a value and an error); PartialReadBytes extracts it, empty if none.
inline constexpr char kPartialReadPayloadUrl[] =
    "type.googleapis.com/drivegw.transport.PartialRead";
std::vector<uint8_t> PartialReadBytes(const absl::Status& status);

struct SerialPortCounters {
  uint64_t bytes_in = 0;       // bytes returned by reads
  uint64_t bytes_out = 0;      // bytes accepted by the kernel
  uint64_t timeouts = 0;       // ReadExactly / Write deadlines that expired
  uint64_t flushes = 0;        // Flush() calls that succeeded
  uint64_t bytes_flushed = 0;  // bytes pending in the input queue when Flush() discarded it
  uint64_t breaks = 0;         // SendBreak() calls that succeeded
  uint64_t wakeups = 0;        // reads released by Wake()
  uint64_t errors = 0;         // read/write/termios failures
};

// Move-only; the destructor closes the device. Threading (mutex-free by design): one owner
// thread makes every call, which is what the protocol wants anyway (trinamic-sixpack.md §2.5
// L357: no interlacing, a session serialises its requests). Wake() is the one exception: any
// thread may call it to release the owner from a blocked read. Moving or destroying may not
// overlap a Wake().
class SerialPort {
 public:
  // Opens `config.device` O_RDWR|O_NOCTTY|O_NONBLOCK|O_CLOEXEC, raw 8N1 (cfmakeraw, CS8, no
  // parity, one stop bit), CLOCAL|CREAD, no RTS/CTS and no XON/XOFF (§2.1: CTS is ignored; §2.7),
  // sets the speed, reads it back and flushes both queues. Errors name the device and the errno
  // text: "serial /dev/ttyUSB9: open: No such file or directory" (Unavailable; InvalidArgument
  // for a bad config or a device that is not a terminal).
  static absl::StatusOr<SerialPort> Open(const SerialConfig& config);

  SerialPort(SerialPort&& other) noexcept;
  SerialPort& operator=(SerialPort&& other) noexcept;
  SerialPort(const SerialPort&) = delete;
  SerialPort& operator=(const SerialPort&) = delete;
  ~SerialPort();

  const SerialConfig& config() const { return config_; }
  bool is_open() const { return fd_ >= 0; }
  // The speed the device reports now (tcgetattr + cfgetospeed), as a baud number.
  absl::StatusOr<int> ReadBackBaud() const;
  // Changes the speed of the open port (e.g. after the peer was told to switch, trinamic-sixpack.md
  // G-40): tcsetattr(TCSADRAIN), so bytes already queued leave at the old rate first, then reads
  // the speed back. InvalidArgument "serial.baud: ..." for an unsupported rate (the port keeps
  // its speed); Unavailable naming the device when the driver refuses or keeps another speed.
  // config().baud follows a successful change.
  absl::Status SetBaud(int baud);

  // Writes every byte, waiting in poll() on EAGAIN and after partial writes, within a deadline of
  // twice the bytes' line time plus one second (DeadlineExceeded naming how many went out).
  // RS-485: first waits out the line-release guard after the last received byte, then tcdrain()s
  // and returns no earlier than `turnaround` after the last byte left (§2.5).
  absl::Status Write(std::span<const uint8_t> bytes);

  // Exactly `n` bytes within `timeout`. DeadlineExceeded "serial X: read: 4 of 9 bytes within
  // 20ms" on time-out, Cancelled on Wake(), Unavailable when the line hangs up or fails; each
  // error carries the bytes that did arrive (PartialReadBytes). They are consumed: resync is the
  // caller's (Flush / SendBreak, §2.6).
  absl::StatusOr<std::vector<uint8_t>> ReadExactly(size_t n, std::chrono::nanoseconds timeout);

  // Waits up to `timeout` for the first byte, then returns everything already queued. Empty on
  // time-out or Wake() (not errors); Unavailable when the line hangs up or fails.
  absl::StatusOr<std::vector<uint8_t>> ReadAvailable(std::chrono::nanoseconds timeout);

  // Discards the input queue (tcflush TCIFLUSH): resynchronisation after garbage (§2.6).
  absl::Status Flush();

  // Break condition: the PACK aborts a partial word on it (§2.3 L279). 0 ms = tcsendbreak(fd, 0)
  // (0.25-0.5 s); otherwise TIOCSBRK, sleep, TIOCCBRK. On a pseudo-terminal both succeed and
  // deliver nothing to the peer (§2.7, G-39): tests need the simulator's out-of-band hook.
  absl::Status SendBreak(std::chrono::milliseconds duration);

  // Makes one blocked (or the next) read return at once (eventfd). Thread-safe.
  void Wake();

  const SerialPortCounters& counters() const { return counters_; }

 private:
  SerialPort(int fd, int wake_fd, SerialConfig config)
      : fd_(fd), wake_fd_(wake_fd), config_(std::move(config)) {}
  void Close();
  std::string Where() const;
  void NoteReceived(size_t n);

  int fd_ = -1;
  int wake_fd_ = -1;  // eventfd: readable while a wake-up is pending
  SerialConfig config_;
  SerialPortCounters counters_;
  // RS-485: when the last byte arrived; Write keeps the line quiet until + turnaround.
  std::chrono::steady_clock::time_point last_rx_{};
};

namespace serial_detail {

// Shared by SerialPort and PseudoTerminal: deadline-bounded I/O on a non-blocking descriptor.
// `where` prefixes messages ("serial /dev/pts/3"). wake_fd may be -1.
//
// Reads into `out` until it holds `want` bytes (OK), or, with `any`, until at least one byte
// came and the queue is empty (OK). Otherwise DeadlineExceeded at the deadline, Cancelled on a
// wake-up, Unavailable on hang-up or a read error; `out` keeps whatever arrived.
absl::Status ReadUntil(int fd, int wake_fd, size_t want, bool any,
                       std::chrono::steady_clock::time_point deadline, const std::string& where,
                       std::vector<uint8_t>& out);
// Writes all of `bytes`, polling for POLLOUT on EAGAIN; `written` counts what the kernel took.
absl::Status WriteAll(int fd, std::span<const uint8_t> bytes,
                      std::chrono::steady_clock::time_point deadline, const std::string& where,
                      size_t& written);
// now + timeout, clamped so that nanoseconds::max() cannot overflow.
std::chrono::steady_clock::time_point DeadlineAfter(std::chrono::nanoseconds timeout);
// Attaches `bytes` as the kPartialReadPayloadUrl payload.
absl::Status WithPartial(absl::Status status, const std::vector<uint8_t>& bytes);

}  // namespace serial_detail
}  // namespace drivegw::transport
