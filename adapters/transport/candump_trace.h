// candump log lines ("(1700000000.123456) can0 42E#004B030103 T"): formatter, parser, and a
// thread-safe append-only trace file shared by the CAN back ends (docs/decisions/803).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/transport/can_frame.h"

namespace drivegw::transport {

// Trailing "T"/"R" as candump -x and python-can's CanutilsLogReader write and read it.
enum class CanDirection { kRx, kTx };

struct CandumpRecord {
  int64_t seconds = 0;        // UTC seconds since the epoch
  uint32_t microseconds = 0;  // 0..999999
  std::string interface;      // "can0"; no white space
  CanFrame frame;
  std::optional<CanDirection> direction;  // absent in plain candump -l lines

  friend bool operator==(const CandumpRecord&, const CandumpRecord&) = default;
};

// One line without the newline: "(%010lld.%06u) IFACE BODY[ T|R]" (BODY: FormatCanFrame).
std::string FormatCandumpLine(const CandumpRecord& record);

// The inverse; also accepts what candump -l writes (no direction, tabs, '.' between data bytes,
// a trailing newline). InvalidArgument "candump line: <what> (<field>=...)" otherwise; CAN FD
// lines ("##") are refused (classic CAN only, docs/decisions/801).
absl::StatusOr<CandumpRecord> ParseCandumpLine(std::string_view line);

// Appends one line per frame to a file (O_APPEND, one write(2) per line, so several buses and
// processes may share a file without tearing lines). Record is thread-safe and never fails:
// write errors are counted.
class CandumpTrace {
 public:
  using WallClock = std::function<std::chrono::system_clock::time_point()>;

  // Creates or appends to `path` (mode 0644). Unavailable naming the path and errno text.
  static absl::StatusOr<std::shared_ptr<CandumpTrace>> Open(const std::string& path,
                                                            WallClock wall_clock = {});
  ~CandumpTrace();
  CandumpTrace(const CandumpTrace&) = delete;
  CandumpTrace& operator=(const CandumpTrace&) = delete;

  void Record(std::string_view interface, const CanFrame& frame, CanDirection direction) noexcept;

  const std::string& path() const { return path_; }
  uint64_t lines() const { return lines_.load(std::memory_order_relaxed); }
  uint64_t write_errors() const { return write_errors_.load(std::memory_order_relaxed); }

 private:
  CandumpTrace(int fd, std::string path, WallClock wall_clock)
      : fd_(fd), path_(std::move(path)), wall_clock_(std::move(wall_clock)) {}

  int fd_;
  std::string path_;
  WallClock wall_clock_;
  std::atomic<uint64_t> lines_{0};
  std::atomic<uint64_t> write_errors_{0};
};

}  // namespace drivegw::transport
