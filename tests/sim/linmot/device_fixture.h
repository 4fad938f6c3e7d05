// Test fixture driving a LinMotDevice the way a LinUDP master would, on simulated time only.
#pragma once

#include <chrono>
#include <cmath>
#include <memory>
#include <optional>

#include "adapters/linmot/linudp/codec.h"
#include "adapters/linmot/mc/control_word.h"
#include "adapters/linmot/mc/motion_command.h"
#include "adapters/linmot/mc/state_var.h"
#include "adapters/linmot/mc/status_word.h"
#include "gtest/gtest.h"
#include "sim/linmot/device.h"

namespace drivegw::sim::linmot::testing {

namespace mc = ::drivegw::linmot::mc;
namespace linudp = ::drivegw::linmot::linudp;
using std::chrono::milliseconds;

// Test options: 1 ms tick, a 300 mm stroke so that case A of linmot-mc.md §6.1 (200 mm) fits.
inline SimOptions TestOptions() {
  SimOptions o;
  o.name = "test";
  o.stroke_min_mm = 0;
  o.stroke_max_mm = 300;
  o.initial_position_mm = 10;
  o.home_position_mm = 0;
  o.boot_time = milliseconds(100);
  return o;
}

class DeviceFixture : public ::testing::Test {
 protected:
  void SetUp() override { Make(TestOptions()); }

  void Make(const SimOptions& o) {
    auto d = LinMotDevice::Create(o);
    ASSERT_TRUE(d.ok()) << d.status();
    dev_ = std::move(*d);
    mc_count_ = 0;
  }

  std::optional<linudp::Reply> TrySend(const linudp::Request& r) { return dev_->Handle(r); }
  linudp::Reply Send(const linudp::Request& r) {
    auto reply = dev_->Handle(r);
    EXPECT_TRUE(reply.has_value()) << "drive did not answer";
    return reply.value_or(linudp::Reply{});
  }
  // A control word telegram with the standard status blocks back.
  linudp::Reply Cw(uint16_t cw) {
    linudp::Request r;
    r.response_definition = linudp::kRespStandard;
    r.control_word = cw;
    return Send(r);
  }
  linudp::Reply Poll() {
    linudp::Request r;
    r.response_definition = linudp::kRespStandard;
    return Send(r);
  }
  // An MC command with an explicit count.
  std::optional<linudp::Reply> McRaw(const mc::McCommand& c, uint8_t count) {
    auto block = mc::EncodeMotionCommand(c, count);
    EXPECT_TRUE(block.ok()) << block.status();
    linudp::Request r;
    r.response_definition = linudp::kRespStandard;
    r.motion_command = block.value_or(mc::McBlock{});
    return dev_->Handle(r);
  }
  // An MC command with the next count of the D-09 ring.
  linudp::Reply Mc(const mc::McCommand& c) {
    mc_count_ = mc::NextCount(mc_count_);
    auto reply = McRaw(c, mc_count_);
    EXPECT_TRUE(reply.has_value());
    return reply.value_or(linudp::Reply{});
  }
  void Ms(int ms) { dev_->Advance(milliseconds(ms)); }

  uint8_t Main() const { return dev_->main_state(); }
  mc::StatusWord Sw() const { return mc::StatusWord{dev_->status_word()}; }
  mc::StateVar Sv() const { return mc::StateVar::FromRaw(dev_->state_var()); }
  double DemandMm() const { return dev_->Snapshot().demand_position_mm; }
  double DemandVelocity() const { return dev_->Snapshot().demand_velocity_mm_s; }

  // linmot-mc.md §2.7 steps 1-2: 0000h, 003Eh, 003Fh, wait for the HW tests.
  void SwitchOn() {
    Cw(mc::kAllOff);
    Cw(mc::kSwitchedOff);
    Cw(mc::kOperational);
    Ms(310);
    Cw(mc::kOperational);
    ASSERT_EQ(Main(), 8);
  }
  // §2.7 step 3: home, hold until sub state 0Fh, release.
  void Home() {
    Cw(mc::kHoming);
    for (int i = 0; i < 20000 && Sv().raw() != 0x090F; ++i) Ms(1);
    ASSERT_EQ(Sv().raw(), 0x090F);
    Cw(mc::kOperational);
    ASSERT_EQ(Main(), 8);
    ASSERT_TRUE(Sw().homed());
  }
  // "Ready" of linmot-mc.md §14: state 8, homed, at 0.
  void Ready() {
    SwitchOn();
    Home();
    Ms(5);
    ASSERT_NEAR(DemandMm(), 0.0, 1e-9);
  }

  std::unique_ptr<LinMotDevice> dev_;
  uint8_t mc_count_ = 0;
};

// Case-A style limits in wire units: 1 m/s, 10 m/s², 5 m/s².
inline mc::McCommand GoTo(double mm, uint32_t v = 1'000'000, uint32_t a = 1'000'000,
                          uint32_t d = 500'000) {
  return mc::VaiGoToPos(static_cast<int32_t>(std::llround(mm * 1e4)), v, a, d);
}

}  // namespace drivegw::sim::linmot::testing
