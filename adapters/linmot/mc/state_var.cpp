// Names of the LinMot MC SW main states (linmot-mc.md §2.2, MC22 L497-520).
#include "adapters/linmot/mc/state_var.h"

namespace drivegw::linmot::mc {

const char* MainStateName(uint8_t main_state) {
  // The state var table's names; state 7 from its section title (errata 2), 14 and 21 as
  // in §2.2.
  static constexpr const char* kNames[kMainStateCount] = {
      "Not Ready To Switch On",
      "Switch On Disabled",
      "Ready To Switch On",
      "Setup Error",
      "Error",
      "HW Tests",
      "Ready To Operate",
      "Brake Release Delay",
      "Operation Enabled",
      "Homing",
      "Clearance Check",
      "Going To Initial Position",
      "Aborting",
      "Freezing",
      "Error Behaviour Quick Stop",
      "Going To Position",
      "Jogging +",
      "Jogging -",
      "Linearizing",
      "Phase Searching",
      "Special Mode",
      "Brake Set Delay",
  };
  return main_state < kMainStateCount ? kNames[main_state] : "Unknown State";
}

}  // namespace drivegw::linmot::mc
