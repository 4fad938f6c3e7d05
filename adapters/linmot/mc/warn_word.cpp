// Names of the LinMot MC SW warn word bits (linmot-mc.md §3.3, MC22 L714-754).
#include "adapters/linmot/mc/warn_word.h"

namespace drivegw::linmot::mc {

const char* WarnBitName(int bit) {
  static constexpr const char* kNames[16] = {
      "Motor Hot Sensor",
      "Motor Short Time Overload I2t",
      "Motor Supply Voltage Low",
      "Motor Supply Voltage High",
      "Position Lag Always",
      "Reserved 5",
      "Drive Hot",
      "Motor Not Homed",
      "PTC Sensor 1 Hot",
      "PTC Sensor 2 Hot",
      "RR Hot Calculated",  // unnamed in MC22, MC15 name (errata 25)
      "Speed Lag Always",
      "Position Sensor",
      "Reserved 13",
      "Interface Warn Flag",
      "Application Warn Flag",
  };
  return bit >= 0 && bit < 16 ? kNames[bit] : "Unknown Warn Bit";
}

std::vector<std::string> WarnWord::SetBitNames() const {
  std::vector<std::string> out;
  for (int bit = 0; bit < 16; ++bit) {
    if (test(bit)) out.emplace_back(WarnBitName(bit));
  }
  return out;
}

}  // namespace drivegw::linmot::mc
