// Contract fixture of the STOBER family: the simulated STOBER axis (sim/stober AxisServer) on the
// UDP multicast CAN bus (a port of its own per fixture), referenced at power-on with homing
// method 35 (define home), and the drive from CreateStoberDrive.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <random>

#include "adapters/stober/factory.h"
#include "adapters/stober/param_id.h"
#include "sim/stober/server.h"
#include "tests/contract/family_fixture.h"

namespace drivegw::contract {
namespace {

using namespace std::chrono_literals;
namespace st = drivegw::stober;
namespace ss = drivegw::sim::stober;

constexpr uint8_t kNode = 17;

uint32_t Id(const char* param) {
  const st::CanOpenAddress a = *st::ToCanOpen(st::P(param));
  return static_cast<uint32_t>(a.index) << 8 | a.sub_index;
}

class StoberFixture final : public FamilyFixture {
 public:
  absl::Status Start(DriveRegistry& registry) override {
    static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
    CanBusConfig bus;
    bus.kind = CanBusConfig::Kind::kUdpMulticast;
    bus.group = "239.74.163.98";
    bus.port = static_cast<uint16_t>(20000 + rng() % 20001);
    ss::AxisServerOptions o;
    o.node_id = kNode;
    o.can = bus;
    auto server = ss::AxisServer::Start(o, SteadyClock::Instance());
    if (!server.ok()) return server.status();
    server_ = std::move(*server);
    // §10.1 fixtures: referenced (MoveAbsolute needs I86 = 1, decision 1149); Home defines the
    // reference where the axis stands (A586 = 35, method O, decision 1150).
    server_->WithAxis([](ss::MotionCore& c) {
      c.SetReferenced(true);
      (void)c.Write(st::P("A586"), 35);
    });
    registry.Register(st::kFamilyName, st::CreateStoberDrive);

    config_.name = "s1";
    config_.family = st::kFamilyName;
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 100;
    config_.axis.max_velocity_mm_s = 1000;
    config_.axis.max_acceleration_mm_s2 = 10000;
    config_.timeouts.homing = 5000ms;
    config_.can = bus;
    config_.node_id = kNode;
    config_.canopen.heartbeat = 50ms;
    config_.canopen.heartbeat_timeout = 200ms;
    config_.canopen.sdo_timeout = 300ms;
    return absl::OkStatus();
  }
  DriveConfig config() const override { return config_; }
  void Stop() override {
    if (server_) server_->Stop();
  }

  absl::Status InjectFault(bool fatal) override {
    if (fatal) {
      return absl::UnimplementedError(
          "stober: every CiA 402 fault is reset with control word bit 7 (no fatal fault)");
    }
    server_->InjectFollowingError();  // CiA 402 Fault + EMCY 8611h (decision 1178)
    return absl::OkStatus();
  }
  absl::StatusOr<std::string> InjectWarning() override {
    server_->ForceLimitSwitch(true, true);  // I441 at standstill: a warning, not a fault
    return std::string("positive limit switch active (I441)");
  }
  absl::Status SetAnswering(bool answering) override {
    server_->SetSilent(!answering);
    return absl::OkStatus();
  }
  absl::StatusOr<ParameterRef> WritableParameter() const override {
    return ParameterRef{Id("I10"), false};  // maximum velocity, u/s
  }
  int64_t WritableParameterValue() const override { return 800; }
  absl::StatusOr<ParameterRef> UnknownParameter() const override {
    return ParameterRef{0x5FFF00, false};  // no object at 5FFFh (SDO abort 0602 0000h)
  }
  double PositionResolutionMm() const override { return 0.001; }
  bool HasStoredParameters() const override { return false; }  // decision 1201: no 1010h
  // A silent node hears no gateway heartbeat either: its 1016h consumer times out and 6007h = 3
  // quick-stops it into Switch on disabled (decision 1483); the gateway does not re-enable it.
  bool EnabledAcrossLinkLoss() const override { return false; }

 private:
  std::unique_ptr<ss::AxisServer> server_;
  DriveConfig config_;
};

}  // namespace

std::unique_ptr<FamilyFixture> MakeStoberFixture() { return std::make_unique<StoberFixture>(); }

}  // namespace drivegw::contract
