// Shared helpers of the Trinamic PACK contract cases (trinamic-sixpack.md §8): the simulated
// SIXpack on a real pty driven from the slave side like a host, with a ManualClock, in one reply
// framing (G-01); the same on the UDP multicast CAN bus; wire-word builders.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/serial_port.h"
#include "sim/trinamic/can_server.h"
#include "sim/trinamic/server.h"

namespace drivegw::sim::trinamic::contract {

using Bytes = std::vector<uint8_t>;
using namespace std::chrono_literals;

inline constexpr uint8_t kA = 0x01;   // common setup: A = 0x01 (§8)
inline constexpr uint8_t kRa = 0xF0;  // RA = 0xF0 (§2.4, §8)

// `A op motnr value(i32 LE) 00 00`: the `$23 $24 $26 $27` word layout (L701, L475).
Bytes Word32(uint8_t op, uint8_t motor, int32_t value, uint8_t address = kA);
// `A op motnr RA 00 …`: the `$20 $21 $30` query layout.
Bytes QueryWord(uint8_t op, uint8_t motor, uint8_t address = kA);
// The `$20` body `20 motnr pos(i32) action stopflag` (L657-663).
Bytes Body20(uint8_t motor, int32_t position, uint8_t action = 0, uint8_t stop_flag = 0);
// Little-endian int32 / int16 of a reply body at byte `at`.
int32_t BodyI32(const Bytes& body, size_t at);
int16_t BodyI16(const Bytes& body, size_t at);
std::string Hex(const Bytes& bytes);
const char* FramingName(ReplyFraming framing);

// The contract's common setup (§8): SIXpack, A = 01, factory defaults, 24 V, 19200 baud, reply
// after the 6 ms switchover (turnaround on) in `framing`.
ServerOptions CommonSetup(ReplyFraming framing);

// One simulated RS-232/RS-485 line on a real pty with a ManualClock.
class PackLine {
 public:
  explicit PackLine(const ServerOptions& options);
  PackLine(const PackLine&) = delete;
  PackLine& operator=(const PackLine&) = delete;

  ReplyFraming framing() const { return framing_; }
  bool ok() const { return server != nullptr && port.has_value(); }

  // Writes raw bytes and waits (real-time deadline) until the server has read all of them, so a
  // following clock step is seen after their arrival. Tracks `$40` (switchover) it writes.
  void Write(const Bytes& bytes);
  // Writes a query word, advances the clock by the switchover time (0 without turnaround) and
  // returns exactly the reply bytes in this framing (8 or 9), empty on a time-out.
  Bytes Query(const Bytes& word);
  // The reply body of Query (the R9 prefix checked to be RA and removed).
  Bytes Body(const Bytes& word);
  // The wire bytes of `body` in this framing (G-01: bare for R8, RA first for R9).
  Bytes Wire(const Bytes& body) const;
  // Advances the injected clock and makes the server catch up before returning.
  void Advance(Duration d);
  // Forces the server to advance to the clock now (its loop would within 5 ms of real time).
  void Settle();
  // Whatever arrives within `real` wall time: for "no reply" checks only, never for timing.
  Bytes Drain(std::chrono::milliseconds real = 40ms);
  // `$20` / `$21` fields of motor `m`.
  int32_t Position(uint8_t m) { return BodyI32(Body(QueryWord(0x20, m)), 2); }
  int Action(uint8_t m) { return Body(QueryWord(0x20, m)).at(6); }
  int Velocity(uint8_t m) { return BodyI16(Body(QueryWord(0x21, m)), 2); }
  // Polls `$20` of motor `m` in steps of `step` until action 0 (or `limit` passes).
  void RunUntilIdle(uint8_t m, Duration step = 100ms, Duration limit = 30s);
  // Runs `fn` on unit `index`'s controller at the current clock (world model, introspection).
  void WithUnit(size_t index, const std::function<void(Controller&)>& fn);

  ManualClock clock;
  std::unique_ptr<TrinamicServer> server;
  std::optional<transport::SerialPort> port;

 private:
  ReplyFraming framing_;
  Duration switchover_ = 6ms;
  bool turnaround_ = true;
  uint64_t written_ = 0;
};

// Runs `body` once per reply framing R8 and R9 (G-01), each on a fresh line built from
// CommonSetup(framing) changed by `adjust`.
void ForBothFramings(const std::function<void(ServerOptions&)>& adjust,
                     const std::function<void(PackLine&)>& body);
inline void ForBothFramings(const std::function<void(PackLine&)>& body) {
  ForBothFramings([](ServerOptions&) {}, body);
}

// The simulated PACK on the UDP multicast CAN bus (random port) and a host channel.
class CanPack {
 public:
  explicit CanPack(CanServerOptions options = {});
  bool ok() const { return host != nullptr && server != nullptr; }
  void Send(uint32_t id, const Bytes& data);
  // The next frame within `real` wall time; nullopt if none.
  std::optional<transport::CanFrame> Next(std::chrono::milliseconds real = 2000ms);
  // Waits until the server has taken `n` frames from the bus.
  void WaitFrames(uint64_t n);
  void Settle() {
    server->WithController([](Controller&) {});
  }

  ManualClock clock;
  std::unique_ptr<transport::CanChannel> host;
  std::unique_ptr<TrinamicCanServer> server;
};

Bytes FrameData(const transport::CanFrame& frame);

}  // namespace drivegw::sim::trinamic::contract
