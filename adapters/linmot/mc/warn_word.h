// LinMot MC SW warn word (drive -> master): bit masks and the names of set bits (linmot-mc.md
// §3.3).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace drivegw::linmot::mc {

// linmot-mc.md §3.3 (MC22 L714-754; bit 10 named from MC15, errata 25).
struct WarnWord {
  uint16_t raw = 0;

  static constexpr uint16_t kMotorHotSensor = 1u << 0;
  static constexpr uint16_t kMotorShortTimeOverload = 1u << 1;
  static constexpr uint16_t kMotorSupplyVoltageLow = 1u << 2;
  static constexpr uint16_t kMotorSupplyVoltageHigh = 1u << 3;
  static constexpr uint16_t kPositionLagAlways = 1u << 4;
  static constexpr uint16_t kReserved5 = 1u << 5;
  static constexpr uint16_t kDriveHot = 1u << 6;
  static constexpr uint16_t kMotorNotHomed = 1u << 7;  // D-41
  static constexpr uint16_t kPtcSensor1Hot = 1u << 8;
  static constexpr uint16_t kPtcSensor2Hot = 1u << 9;  // "Reserved PTC 2"
  static constexpr uint16_t kRrHotCalculated = 1u << 10;
  static constexpr uint16_t kSpeedLagAlways = 1u << 11;
  static constexpr uint16_t kPositionSensor = 1u << 12;
  static constexpr uint16_t kReserved13 = 1u << 13;
  static constexpr uint16_t kInterfaceWarnFlag = 1u << 14;
  static constexpr uint16_t kApplicationWarnFlag = 1u << 15;

  constexpr bool any() const { return raw != 0; }  // = status word bit 7
  constexpr bool test(int bit) const { return bit >= 0 && bit < 16 && ((raw >> bit) & 1u) != 0; }

  // Names of the set bits, lowest bit first, in the manual's words ("Motor Not Homed", ...).
  std::vector<std::string> SetBitNames() const;
  friend constexpr bool operator==(WarnWord, WarnWord) = default;
};

// Name of warn word bit 0..15 ("Motor Hot Sensor"); "Unknown Warn Bit" outside 0..15.
const char* WarnBitName(int bit);

}  // namespace drivegw::linmot::mc
