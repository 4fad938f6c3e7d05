// A small device model for the sim/canopen tests: a few application objects with ranges, hooks
// and mapping flags, and a record of every callback.
#pragma once

#include <utility>
#include <vector>

#include "adapters/canopen/sdo.h"
#include "sim/canopen/device_model.h"
#include "sim/canopen/node.h"

namespace drivegw::sim::canopen::testing {

class TestModel : public DeviceModel {
 public:
  absl::Status Configure(SlaveNode& node) override {
    ObjectDictionary& od = node.dictionary();
    for (ObjectDef d : {
             Integer(0x2000, 0, "setpoint", DataType::kU16, Access::kRw, 100)
                 .Range(10, 1000)
                 .Mappable(),
             Integer(0x2001, 0, "offset", DataType::kI32).Mappable(),
             Integer(0x2002, 0, "counter", DataType::kU8, Access::kRo).Mappable(),
             String(0x2003, 0, "label", "abc", Access::kRw).MaxSize(32),
             Integer(0x2004, 0, "password", DataType::kU32, Access::kWo),
             Integer(0x2005, 0, "not mappable", DataType::kU16),
             Integer(0x2006, 0, "big", DataType::kU64).Mappable(),
             Integer(0x6040, 0, "controlword", DataType::kU16).Mappable(),
             Integer(0x6041, 0, "statusword", DataType::kU16, Access::kRo).Mappable(),
             Integer(0x6064, 0, "position actual", DataType::kI32, Access::kRo).Mappable(),
         }) {
      if (absl::Status s = od.Add(d); !s.ok()) return s;
    }
    // Read hooks: the model computes values at the instant they are read.
    absl::Status s =
        od.OnReadInt(0x6064, 0, [this]() -> absl::StatusOr<int64_t> { return position; });
    if (s.ok())
      s = od.OnReadInt(0x6041, 0, [this]() -> absl::StatusOr<int64_t> { return statusword; });
    // A write hook refusing controlword 0xFFFF in the current device state.
    if (s.ok())
      s = od.OnWriteInt(0x6040, 0, [this](int64_t v) -> absl::Status {
        if (v == 0xFFFF) {
          return drivegw::canopen::SdoAbortStatus(drivegw::canopen::SdoAbortCode::kDeviceState,
                                                  "6040h: 0xFFFF refused");
        }
        controlwords.push_back(static_cast<uint16_t>(v));
        return absl::OkStatus();
      });
    return s;
  }
  void Tick(SlaveNode&, Duration dt) override {
    ticked += dt;
    position += static_cast<int32_t>(velocity * ToSeconds(dt));
  }
  void OnRpdoWritten(SlaveNode&, uint16_t number) override { rpdos.push_back(number); }
  void OnNmtChange(SlaveNode&, NmtState from, NmtState to) override { nmt.emplace_back(from, to); }
  void OnResetApplication(SlaveNode&) override {
    ++resets;
    position = 0;
    velocity = 0;
  }

  int32_t position = 0;
  double velocity = 0;  // counts per second
  uint16_t statusword = 0x0250;
  Duration ticked{};
  std::vector<uint16_t> controlwords;
  std::vector<uint16_t> rpdos;
  std::vector<std::pair<NmtState, NmtState>> nmt;
  int resets = 0;
};

}  // namespace drivegw::sim::canopen::testing
