// Wire observation seam shared by every family: the per-drive wire trace (issue 7, switched at
// run time through Drive::SetWireTrace) and round-trip times of request/reply exchanges, which
// the composition root turns into histograms (server/ops, docs/decisions/021-metrics.md).
// Adapters call these; nothing here knows about metrics or the API.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "adapters/core/clock.h"

namespace drivegw::wire {

// One trace line at info level (shown unless logging is off, since an operator asked for it):
// "event=wire drive=x1 family=linmot-linudp dir=tx bytes=0a0b..." and, when not empty, what=.
void Trace(std::string_view drive, std::string_view family, std::string_view dir,
           std::span<const uint8_t> bytes, std::string_view what = {});
// The same with a preformatted frame (CAN frames as candump bodies "42E#004B0301").
void TraceText(std::string_view drive, std::string_view family, std::string_view dir,
               std::string_view frame);

// Receives one round trip (request sent -> its reply); installed once by the composition root.
// Must be quick and thread-safe: it is called on I/O threads, some holding their session lock.
using RoundTripSink = void (*)(std::string_view family, std::string_view drive, double seconds);
void SetRoundTripSink(RoundTripSink sink) noexcept;
void ObserveRoundTrip(std::string_view family, std::string_view drive, Duration elapsed) noexcept;

}  // namespace drivegw::wire
