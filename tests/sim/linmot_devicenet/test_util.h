// Shared helpers of the simulated LinMot DeviceNet drive tests: byte strings in the reference's
// dotted notation and the §13.1 fixtures (linmot-devicenet.md §0.4, §13.1).
#pragma once

#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "adapters/linmot/devicenet/codec.h"
#include "adapters/linmot/devicenet/codec_io.h"
#include "sim/linmot_devicenet/options.h"

namespace drivegw::sim::linmot_devicenet::testing {

// "02.00.11.10" -> {0x02, 0x00, 0x11, 0x10}; "" -> {}.
inline std::vector<uint8_t> Bytes(std::string_view dotted) {
  std::vector<uint8_t> out;
  std::string hex;
  for (char c : dotted) {
    if (c != '.' && c != ' ') hex.push_back(c);
  }
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

// The inverse: upper-case hex bytes joined by dots.
inline std::string Dotted(std::span<const uint8_t> bytes) {
  std::string out;
  char buf[4];
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::snprintf(buf, sizeof(buf), "%02X", bytes[i]);
    if (i) out += '.';
    out += buf;
  }
  return out;
}

// "42D#02.00.11.10.00.14" (§0.4).
inline dn::Frame F(std::string_view text) { return dn::ParseFrame(text).value(); }
inline std::string Text(const dn::Frame& f) { return dn::FrameToString(f); }

// F1 (§13.1): NET (MAC 5, parameter) + motor A master, LinMot, serial, initialised; candidate P.
inline DnSimOptions F1Options() {
  DnSimOptions o;
  o.name = "f1";
  o.mac_source = MacIdSource::kParameter;
  o.mac_id = 5;
  o.motor_count = 1;
  o.initialised = true;
  o.poll_modules = dn::DefaultLayoutP().modules;
  return o;
}

// F1' : F1 without Control In (4 / 8 bytes).
inline DnSimOptions F1PrimeOptions() {
  DnSimOptions o = F1Options();
  o.poll_modules.control_in = false;
  return o;
}

// F2: seed example 2, masters A and C; Control In, Direct In, Status Out, Direct Out 1.
inline DnSimOptions F2Options() {
  DnSimOptions o = F1Options();
  o.motor_count = 3;
  o.motors[1].master = false;
  for (auto& m : o.motors) {
    m.stroke_min_mm = -200;
    m.stroke_max_mm = 200;
  }
  o.poll_modules = dn::Example2Layout().modules;
  return o;
}

// F3: seed example 1, four master drives, all seven modules (22 / 24 bytes).
inline DnSimOptions F3Options() {
  DnSimOptions o = F1Options();
  o.motor_count = 4;
  o.poll_modules = dn::Example1Layout().modules;
  return o;
}

}  // namespace drivegw::sim::linmot_devicenet::testing
