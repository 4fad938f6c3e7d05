// candump log format: can-utils candump.c (-l) and lib.c sprint_canframe/parse_canframe.
#include "adapters/transport/candump_trace.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace drivegw::transport {
namespace {

constexpr uint32_t kCanErrFlag = 0x20000000;  // linux/can.h CAN_ERR_FLAG
constexpr size_t kMaxInterfaceChars = 64;

absl::Status LineError(std::string_view what) {
  return absl::InvalidArgumentError(absl::StrCat("candump line: ", std::string(what)));
}

int HexDigit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

bool IsBlank(char c) { return c == ' ' || c == '\t'; }

// Splits off the next token separated by blanks; empty when none is left.
std::string_view NextToken(std::string_view& rest) {
  size_t i = 0;
  while (i < rest.size() && IsBlank(rest[i])) ++i;
  size_t j = i;
  while (j < rest.size() && !IsBlank(rest[j])) ++j;
  const std::string_view token = rest.substr(i, j - i);
  rest.remove_prefix(j);
  return token;
}

std::string Quoted(std::string_view s) {
  // Bounded so a huge garbage line does not make a huge message.
  return absl::StrCat("'", std::string(s.substr(0, 40)), s.size() > 40 ? "...'" : "'");
}

absl::Status ParseTimestamp(std::string_view token, CandumpRecord& record) {
  if (token.size() < 4 || token.front() != '(' || token.back() != ')') {
    return LineError(absl::StrCat("timestamp ", Quoted(token), " is not (SECONDS.MICROS)"));
  }
  token = token.substr(1, token.size() - 2);
  const size_t dot = token.find('.');
  if (dot == std::string_view::npos || dot == 0 || dot > 18 || token.size() - dot - 1 == 0 ||
      token.size() - dot - 1 > 9) {
    return LineError(absl::StrCat("timestamp ", Quoted(token), " is not SECONDS.MICROS"));
  }
  int64_t seconds = 0;
  for (char c : token.substr(0, dot)) {
    if (c < '0' || c > '9')
      return LineError(absl::StrCat("timestamp ", Quoted(token), " is not decimal"));
    seconds = seconds * 10 + (c - '0');
  }
  // Fractions of other lengths (candump prints 6 digits) are scaled to microseconds.
  uint64_t fraction = 0;
  const std::string_view frac = token.substr(dot + 1);
  for (char c : frac) {
    if (c < '0' || c > '9')
      return LineError(absl::StrCat("timestamp ", Quoted(token), " is not decimal"));
    fraction = fraction * 10 + static_cast<uint64_t>(c - '0');
  }
  for (size_t n = frac.size(); n < 6; ++n) fraction *= 10;
  for (size_t n = frac.size(); n > 6; --n) fraction /= 10;
  record.seconds = seconds;
  record.microseconds = static_cast<uint32_t>(fraction);
  return absl::OkStatus();
}

absl::Status ParseBody(std::string_view body, CanFrame& frame) {
  const size_t hash = body.find('#');
  if (hash == std::string_view::npos) {
    return LineError(absl::StrCat("frame ", Quoted(body), " has no '#'"));
  }
  const std::string_view id_text = body.substr(0, hash);
  std::string_view data = body.substr(hash + 1);
  // lib.c parse_canframe: 3 digits base format, 8 digits extended (or error) format.
  if (id_text.size() != 3 && id_text.size() != 8) {
    return LineError(absl::StrCat("frame.id ", Quoted(id_text),
                                  " must have 3 (11-bit) or 8 (29-bit) hex digits"));
  }
  uint32_t id = 0;
  for (char c : id_text) {
    const int d = HexDigit(c);
    if (d < 0) return LineError(absl::StrCat("frame.id ", Quoted(id_text), " is not hex"));
    id = (id << 4) | static_cast<uint32_t>(d);
  }
  frame = CanFrame{};
  if (id_text.size() == 3) {
    if (id > kCanStandardIdMax) {
      return LineError(absl::StrCat("frame.id ", Quoted(id_text), " exceeds 7FF (11-bit)"));
    }
  } else if (id & kCanErrFlag) {
    if (id & ~(kCanErrFlag | kCanExtendedIdMax)) {
      return LineError(
          absl::StrCat("frame.id ", Quoted(id_text), " has flag bits beyond CAN_ERR_FLAG"));
    }
    frame.error = true;
    frame.extended = true;
    id &= ~kCanErrFlag;
  } else if (id > kCanExtendedIdMax) {
    return LineError(absl::StrCat("frame.id ", Quoted(id_text), " exceeds 1FFFFFFF (29-bit)"));
  } else {
    frame.extended = true;
  }
  frame.id = id;
  if (!data.empty() && data.front() == '#') {
    return LineError("CAN FD frames ('##') are not supported (classic CAN only)");
  }
  if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    frame.rtr = true;
    if (data.size() == 2 && data[1] >= '0' && data[1] <= '8') {
      frame.dlc = static_cast<uint8_t>(data[1] - '0');
    } else if (data.size() != 1) {
      return LineError(absl::StrCat("frame RTR length ", Quoted(data), " is not R or R0..R8"));
    }
    if (frame.error) return LineError("frame: an error frame cannot be RTR");
    return absl::OkStatus();
  }
  uint8_t n = 0;
  for (size_t i = 0; i < data.size();) {
    if (data[i] == '.' && i > 0) {  // lib.c accepts '.' between bytes
      ++i;
      continue;
    }
    if (i + 1 >= data.size()) {
      return LineError(absl::StrCat("frame.data ", Quoted(data), " has an odd number of digits"));
    }
    const int hi = HexDigit(data[i]);
    const int lo = HexDigit(data[i + 1]);
    if (hi < 0 || lo < 0)
      return LineError(absl::StrCat("frame.data ", Quoted(data), " is not hex"));
    if (n == kCanMaxDlc)
      return LineError(absl::StrCat("frame.data ", Quoted(data), " exceeds 8 bytes"));
    frame.data[n++] = static_cast<uint8_t>(hi << 4 | lo);
    i += 2;
  }
  frame.dlc = n;
  return absl::OkStatus();
}

}  // namespace

std::string FormatCandumpLine(const CandumpRecord& record) {
  char ts[48];
  std::snprintf(ts, sizeof(ts), "(%010lld.%06u) ", static_cast<long long>(record.seconds),
                record.microseconds % 1000000u);
  std::string line = absl::StrCat(ts, record.interface, " ", FormatCanFrame(record.frame));
  if (record.direction) line += *record.direction == CanDirection::kTx ? " T" : " R";
  return line;
}

absl::StatusOr<CandumpRecord> ParseCandumpLine(std::string_view line) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || IsBlank(line.back()))) {
    line.remove_suffix(1);
  }
  CandumpRecord record;
  std::string_view rest = line;
  const std::string_view ts = NextToken(rest);
  if (ts.empty()) return LineError("empty");
  if (absl::Status s = ParseTimestamp(ts, record); !s.ok()) return s;
  const std::string_view iface = NextToken(rest);
  if (iface.empty()) return LineError("interface missing");
  if (iface.size() > kMaxInterfaceChars) {
    return LineError(
        absl::StrCat("interface ", Quoted(iface), " exceeds ", kMaxInterfaceChars, " characters"));
  }
  record.interface = std::string(iface);
  const std::string_view body = NextToken(rest);
  if (body.empty()) return LineError("frame missing");
  if (absl::Status s = ParseBody(body, record.frame); !s.ok()) return s;
  const std::string_view dir = NextToken(rest);
  if (dir == "T" || dir == "t") {
    record.direction = CanDirection::kTx;
  } else if (dir == "R" || dir == "r") {
    record.direction = CanDirection::kRx;
  } else if (!dir.empty()) {
    return LineError(absl::StrCat("direction ", Quoted(dir), " is not T or R"));
  }
  if (!NextToken(rest).empty()) return LineError("extra text after the direction");
  return record;
}

absl::StatusOr<std::shared_ptr<CandumpTrace>> CandumpTrace::Open(const std::string& path,
                                                                 WallClock wall_clock) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) {
    return absl::UnavailableError(absl::StrCat("can trace '", path, "': ", std::strerror(errno)));
  }
  if (!wall_clock) wall_clock = [] { return std::chrono::system_clock::now(); };
  return std::shared_ptr<CandumpTrace>(new CandumpTrace(fd, path, std::move(wall_clock)));
}

CandumpTrace::~CandumpTrace() {
  if (fd_ >= 0) ::close(fd_);
}

void CandumpTrace::Record(std::string_view interface, const CanFrame& frame,
                          CanDirection direction) noexcept {
  try {
    const auto since_epoch = wall_clock_().time_since_epoch();
    const auto us = std::chrono::duration_cast<std::chrono::microseconds>(since_epoch).count();
    CandumpRecord record;
    record.seconds = us / 1000000;
    record.microseconds = static_cast<uint32_t>(us % 1000000);
    record.interface = std::string(interface);
    record.frame = frame;
    record.direction = direction;
    const std::string line = FormatCandumpLine(record) + "\n";
    // O_APPEND + one write: the line lands whole at the end even with concurrent writers.
    const ssize_t n = ::write(fd_, line.data(), line.size());
    if (n == static_cast<ssize_t>(line.size())) {
      lines_.fetch_add(1, std::memory_order_relaxed);
    } else {
      write_errors_.fetch_add(1, std::memory_order_relaxed);
    }
  } catch (...) {  // std::bad_alloc: tracing must never take the bus down
    write_errors_.fetch_add(1, std::memory_order_relaxed);
  }
}

}  // namespace drivegw::transport
