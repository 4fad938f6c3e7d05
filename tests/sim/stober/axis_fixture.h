// Test fixtures F-LIN / F-END / F-CYC of stober-motion.md §10.1 around a MotionCore, driven in
// 1 ms cycles (A150 = 1 ms). The model is pure, so cycle-exact assertions are deterministic.
#pragma once

#include <cmath>
#include <functional>
#include <string>

#include "gtest/gtest.h"
#include "sim/stober/motion_core.h"

namespace drivegw::sim::stober::testing {

enum class Fixture { kLin, kEnd, kCyc };

class TestAxis {
 public:
  explicit TestAxis(Fixture fixture = Fixture::kLin, MotionCoreOptions options = {})
      : core_(WithEnabled(std::move(options))) {
    // F-LIN is the catalogue default (decision 1141); F-END and F-CYC differ as §10.1 says.
    if (fixture == Fixture::kEnd) {
      W("I00", 1);
      W("I01", 360);
    }
    if (fixture == Fixture::kCyc) {
      W("A291", 1);
      W("I423", 5);
    }
  }

  MotionCore& core() { return core_; }

  void W(const char* id, double value) {
    absl::Status s = core_.Write(P(id), value);
    ASSERT_TRUE(s.ok()) << id << " = " << value << ": " << s;
  }
  double R(const char* id) const {
    absl::StatusOr<double> v = core_.Read(P(id));
    EXPECT_TRUE(v.ok()) << id;
    return v.ok() ? *v : NAN;
  }
  bool B(const char* id) const { return R(id) != 0; }

  void Advance(int cycles = 1) { core_.Advance(cycles); }

  // "Start X": command number and set values are written, Execute low for one cycle if it was
  // high (G-05), then the rising edge; returns after the start cycle.
  void Start(Command command) {
    W("I401", static_cast<int>(command));
    if (B("I402")) {
      W("I402", 0);
      Advance();
    }
    position_before_edge = R("I80");
    W("I402", 1);
    Advance();
  }
  void ExecuteLow() {
    W("I402", 0);
    Advance();
  }
  void MoveAbsolute(double position) {
    W("I403", position);
    Start(Command::kMoveAbsolute);
  }

  // Runs until `predicate` holds after a cycle; returns the number of cycles, or -1 after
  // `max_cycles`.
  int RunUntil(const std::function<bool()>& predicate, int max_cycles = 20000) {
    for (int i = 1; i <= max_cycles; ++i) {
      Advance();
      if (predicate()) return i;
    }
    return -1;
  }
  int RunUntilDone(int max_cycles = 20000) {
    return RunUntil([&] { return B("I92"); }, max_cycles);
  }

  double position_before_edge = 0;

 private:
  static MotionCoreOptions WithEnabled(MotionCoreOptions options) {
    options.start_operation_enabled = true;
    return options;
  }
  MotionCore core_;
};

}  // namespace drivegw::sim::stober::testing
