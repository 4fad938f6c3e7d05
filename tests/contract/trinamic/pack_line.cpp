// Shared helpers of the Trinamic PACK contract cases: pty line, CAN bus, word builders.
#include "tests/contract/trinamic/pack_line.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <random>
#include <thread>

#include "absl/strings/str_format.h"
#include "gtest/gtest.h"

namespace drivegw::sim::trinamic::contract {
namespace {

std::string TempLink() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          absl::StrFormat("dgw-trct-%d-%d", ::getpid(), n.fetch_add(1)))
      .string();
}

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

template <typename Pred>
bool WaitFor(Pred pred, std::chrono::milliseconds timeout = 3000ms) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (pred()) return true;
    std::this_thread::yield();
  }
  return pred();
}

}  // namespace

Bytes Word32(uint8_t op, uint8_t motor, int32_t value, uint8_t address) {
  const auto u = static_cast<uint32_t>(value);
  return {address,
          op,
          motor,
          static_cast<uint8_t>(u),
          static_cast<uint8_t>(u >> 8),
          static_cast<uint8_t>(u >> 16),
          static_cast<uint8_t>(u >> 24),
          0,
          0};
}

Bytes Body20(uint8_t motor, int32_t position, uint8_t action, uint8_t stop_flag) {
  const auto u = static_cast<uint32_t>(position);
  return {0x20,
          motor,
          static_cast<uint8_t>(u),
          static_cast<uint8_t>(u >> 8),
          static_cast<uint8_t>(u >> 16),
          static_cast<uint8_t>(u >> 24),
          action,
          stop_flag};
}

Bytes QueryWord(uint8_t op, uint8_t motor, uint8_t address) {
  return {address, op, motor, kRa, 0, 0, 0, 0, 0};
}

int32_t BodyI32(const Bytes& body, size_t at) {
  if (body.size() < at + 4) return INT32_MIN;
  return static_cast<int32_t>(uint32_t{body[at]} | uint32_t{body[at + 1]} << 8 |
                              uint32_t{body[at + 2]} << 16 | uint32_t{body[at + 3]} << 24);
}

int16_t BodyI16(const Bytes& body, size_t at) {
  if (body.size() < at + 2) return INT16_MIN;
  return static_cast<int16_t>(body[at] | body[at + 1] << 8);
}

std::string Hex(const Bytes& bytes) {
  std::string out;
  for (uint8_t b : bytes) out += absl::StrFormat("%s%02X", out.empty() ? "" : " ", b);
  return out;
}

const char* FramingName(ReplyFraming framing) { return framing == ReplyFraming::kR8 ? "R8" : "R9"; }

ServerOptions CommonSetup(ReplyFraming framing) {
  ServerOptions o;
  o.controller.address = kA;
  o.controller.axes = 6;
  o.controller.framing = framing;
  o.controller.supply_volts = 24.0;
  o.turnaround = true;
  o.pty_path = TempLink();
  return o;
}

PackLine::PackLine(const ServerOptions& options)
    : framing_(options.controller.framing), turnaround_(options.turnaround) {
  ServerOptions o = options;
  if (o.pty_path.empty()) o.pty_path = TempLink();
  auto s = TrinamicServer::Start(o, clock);
  EXPECT_TRUE(s.ok()) << s.status();
  if (!s.ok()) return;
  server = *std::move(s);
  transport::SerialConfig config;
  config.device = o.pty_path;
  config.baud = 19200;  // §2.1 default
  auto p = transport::SerialPort::Open(config);
  EXPECT_TRUE(p.ok()) << p.status();
  if (p.ok()) port.emplace(*std::move(p));
}

void PackLine::Write(const Bytes& bytes) {
  ASSERT_TRUE(ok());
  ASSERT_TRUE(port->Write(bytes).ok());
  written_ += bytes.size();
  ASSERT_TRUE(WaitFor([&] { return server->counters().bytes_in >= written_; }))
      << "server read " << server->counters().bytes_in << " of " << written_ << " bytes";
  if (bytes.size() == 9 && bytes[1] == 0x40) {
    switchover_ = kTick * (bytes[4] | bytes[5] << 8);  // `$40` P2/P3 (L833)
  }
}

Bytes PackLine::Query(const Bytes& word) {
  Write(word);
  if (turnaround_) Advance(switchover_);
  const size_t n = framing_ == ReplyFraming::kR9 ? 9 : 8;
  auto r = port->ReadExactly(n, 2s);
  EXPECT_TRUE(r.ok()) << "query " << Hex(word) << ": " << r.status();
  return r.ok() ? *r : Bytes{};
}

Bytes PackLine::Body(const Bytes& word) {
  Bytes r = Query(word);
  if (framing_ == ReplyFraming::kR9 && !r.empty()) {
    EXPECT_EQ(r.front(), kRa) << "R9 reply must start with RA: " << Hex(r);
    r.erase(r.begin());
  }
  return r;
}

Bytes PackLine::Wire(const Bytes& body) const {
  if (framing_ == ReplyFraming::kR8) return body;
  Bytes out(body.size() + 1, kRa);  // RA first (R9), then the body
  std::copy(body.begin(), body.end(), out.begin() + 1);
  return out;
}

void PackLine::Advance(Duration d) {
  clock.Advance(d);
  Settle();
}

void PackLine::Settle() {
  server->WithController([](Controller&) {});
}

Bytes PackLine::Drain(std::chrono::milliseconds real) {
  auto r = port->ReadAvailable(real);
  return r.ok() ? *r : Bytes{};
}

void PackLine::RunUntilIdle(uint8_t m, Duration step, Duration limit) {
  const TimePoint end = clock.Now() + limit;
  while (Action(m) != 0 && clock.Now() < end) Advance(step);
}

void PackLine::WithUnit(size_t index, const std::function<void(Controller&)>& fn) {
  server->WithUnit(index, fn);
}

void ForBothFramings(const std::function<void(ServerOptions&)>& adjust,
                     const std::function<void(PackLine&)>& body) {
  for (ReplyFraming framing : {ReplyFraming::kR8, ReplyFraming::kR9}) {
    SCOPED_TRACE(FramingName(framing));
    ServerOptions o = CommonSetup(framing);
    adjust(o);
    PackLine line(o);
    ASSERT_TRUE(line.ok());
    body(line);
  }
}

CanPack::CanPack(CanServerOptions options) {
  const uint16_t port = RandomPort();
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.78";
  bus.port = port;
  auto h = transport::OpenCanChannel(bus);
  EXPECT_TRUE(h.ok()) << h.status();
  if (h.ok()) host = *std::move(h);
  options.can = bus;
  if (options.serial_endpoint && options.serial_pty_path.empty()) {
    options.serial_pty_path = TempLink();
  }
  auto s = TrinamicCanServer::Start(options, clock);
  EXPECT_TRUE(s.ok()) << s.status();
  if (s.ok()) server = *std::move(s);
}

void CanPack::Send(uint32_t id, const Bytes& data) {
  ASSERT_TRUE(host->Send(transport::MakeCanFrame(id, data)).ok());
}

std::optional<transport::CanFrame> CanPack::Next(std::chrono::milliseconds real) {
  const auto deadline = std::chrono::steady_clock::now() + real;
  while (true) {
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::nanoseconds(0)) return std::nullopt;
    auto f = host->Receive(left);
    if (f.ok() && f->has_value()) return **f;
  }
}

void CanPack::WaitFrames(uint64_t n) {
  ASSERT_TRUE(WaitFor([&] { return server->counters().frames_in >= n; }))
      << "server took " << server->counters().frames_in << " of " << n << " frames";
}

Bytes FrameData(const transport::CanFrame& frame) {
  return Bytes(frame.data.begin(), frame.data.begin() + frame.dlc);
}

}  // namespace drivegw::sim::trinamic::contract
