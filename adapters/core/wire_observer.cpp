// Wire trace lines and the round-trip sink (wire_observer.h).
#include "adapters/core/wire_observer.h"

#include <atomic>
#include <chrono>
#include <string>

#include "adapters/core/log.h"

namespace drivegw::wire {
namespace {

std::atomic<RoundTripSink>& Sink() {
  static std::atomic<RoundTripSink> sink{nullptr};
  return sink;
}

void Emit(std::string_view drive, std::string_view family, std::string_view dir,
          std::string_view key, std::string_view value, std::string_view what) {
  // The trace was asked for through the API: it bypasses the info threshold, not "off".
  if (log::GetLevel() == log::Level::kOff) return;
  log::Fields f;
  f.Add("drive", drive).Add("family", family).Add("dir", dir).Add(key, value);
  if (!what.empty()) f.Add("what", what);
  log::Write(log::Level::kInfo, "wire", f.str());
}

}  // namespace

void Trace(std::string_view drive, std::string_view family, std::string_view dir,
           std::span<const uint8_t> bytes, std::string_view what) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  hex.reserve(bytes.size() * 2);
  for (uint8_t b : bytes) {
    hex += kHex[b >> 4];
    hex += kHex[b & 0x0F];
  }
  Emit(drive, family, dir, "bytes", hex, what);
}

void TraceText(std::string_view drive, std::string_view family, std::string_view dir,
               std::string_view frame) {
  Emit(drive, family, dir, "frame", frame, {});
}

void SetRoundTripSink(RoundTripSink sink) noexcept { Sink().store(sink); }

void ObserveRoundTrip(std::string_view family, std::string_view drive, Duration elapsed) noexcept {
  RoundTripSink sink = Sink().load(std::memory_order_relaxed);
  if (sink == nullptr) return;
  sink(family, drive, std::chrono::duration<double>(elapsed).count());
}

}  // namespace drivegw::wire
