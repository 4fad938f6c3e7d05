// Contract fixture of the Trinamic family: the simulated SIXpack (sim/trinamic) on a real
// pseudo-terminal, with a second PACK on the same line that can be switched to our address
// (duplicate address = the fatal fault), and the axis drive from CreateTrinamicDrive.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>

#include "adapters/trinamic/codec.h"
#include "adapters/trinamic/drive.h"
#include "adapters/trinamic/factory.h"
#include "adapters/trinamic/parameters.h"
#include "sim/trinamic/server.h"
#include "tests/contract/family_fixture.h"

namespace drivegw::contract {
namespace {

using namespace std::chrono_literals;
namespace tr = drivegw::trinamic;
namespace trsim = drivegw::sim::trinamic;

constexpr double kMicrostepsPerMm = 10;  // 0.1 mm resolution, defaults of §5.12 otherwise

class TrinamicFixture final : public FamilyFixture {
 public:
  absl::Status Start(DriveRegistry& registry) override {
    static std::atomic<int> n{0};
    trsim::ServerOptions o;
    o.pty_path =
        (std::filesystem::temp_directory_path() /
         ("dgw-contract-trinamic-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
            .string();
    // Reference switch of motor 0 active from 100 microsteps (10 mm) on, ahead of the search
    // (not NullLeft: ascending, L565).
    o.controller.world[0].switch_low = 100;
    o.controller.world[0].switch_high = 1'000'000'000;
    trsim::ControllerOptions second;
    second.address = 2;  // switched to address 1 by InjectFault(true)
    o.more_units.push_back(second);
    auto server = trsim::TrinamicServer::Start(o, SteadyClock::Instance());
    if (!server.ok()) return server.status();
    server_ = std::move(*server);
    registry.Register(tr::kFamilyName, tr::CreateTrinamicDrive);

    config_.name = "t1";
    config_.family = tr::kFamilyName;
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 100;
    // vmax 511 = 25991 µsteps/s = 2599 mm/s; amax <= vstart 10 × 64 = 640 = 254 kµsteps/s²
    // = 25 400 mm/s² (§5.1, §5.3, L556).
    config_.axis.max_velocity_mm_s = 1000;
    config_.axis.max_acceleration_mm_s2 = 20000;
    config_.timeouts.homing = 8000ms;
    TrinamicConfig t;
    t.serial = SerialLineConfig{server_->slave_path(), 19200, false, 6000us};
    t.address = 1;
    t.axis = 0;
    t.axes = 6;
    t.microsteps_per_unit = kMicrostepsPerMm;
    t.poll_period = 5ms;
    t.reply_timeout = 50ms;
    t.offline_after_misses = 2;
    t.parameters = {
        {"$13.vstart", 10},  // amax <= 640 (L556)
        {"$13.vmin", 9},     // fastest exact approach at clkdiv 5 (250 Hz / 25.4 Hz, L543)
        {"$14.amax", 640},
        {"$16.vrefmax", 30},  // short braking after the fast seek
        // No NullCenter/FilterSwitch: the switch edge is the zero point; FastRef, DelayTestNull,
        // StopNoRef (a stop condition just stops, G-10, L597).
        {"$15.motor_type_low", 0x00},
        {"$15.motor_type_high", 0x2A},
        {"$31.max_right", 900},  // analogue stop of motor 0 moving right (InjectFault)
    };
    config_.trinamic = t;
    return absl::OkStatus();
  }
  DriveConfig config() const override { return config_; }
  void Stop() override {
    if (server_) server_->Stop();
  }

  absl::Status InjectFault(bool fatal) override {
    if (fatal) {
      // A second PACK answers at our address (decision 1055): `$42` moves unit 2 to address 1.
      server_->WithUnit(1, [](trsim::Controller& c) {
        (void)c.Handle(*tr::MakeCommand(2, tr::Opcode::kChangeAddress, {1}));
      });
      return absl::OkStatus();
    }
    // Analogue value above `$31` max right while moving right: stop condition, `$20` P6 (L796).
    server_->WithController([](trsim::Controller& c) { c.world(0).analog = 901; });
    return absl::OkStatus();
  }
  absl::StatusOr<std::string> InjectWarning() override {
    // A power cycle of the PACK: the drive re-applies its parameters and warns (CT-57).
    server_->WithController([](trsim::Controller& c) { c.Reset(); });
    return std::string("controller reset: parameters re-applied, re-enable and re-home");
  }
  absl::Status SetAnswering(bool answering) override {
    server_->SetSilent(!answering);
    return absl::OkStatus();
  }
  absl::StatusOr<ParameterRef> WritableParameter() const override {
    return ParameterRef{tr::ParameterId(tr::Opcode::kSetRamp, 3), false};  // $14.vmax
  }
  int64_t WritableParameterValue() const override { return 400; }
  absl::StatusOr<ParameterRef> UnknownParameter() const override {
    return ParameterRef{0x7777, false};
  }
  double PositionResolutionMm() const override { return 1 / kMicrostepsPerMm; }
  bool HasStoredParameters() const override { return false; }  // G-24: the PACK stores nothing

 private:
  std::unique_ptr<trsim::TrinamicServer> server_;
  DriveConfig config_;
};

}  // namespace

std::unique_ptr<FamilyFixture> MakeTrinamicFixture() { return std::make_unique<TrinamicFixture>(); }

}  // namespace drivegw::contract
