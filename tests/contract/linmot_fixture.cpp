// Contract fixture of the LinMot family: the simulated LinMot drive (sim/linmot) on loopback
// UDP and the LinUDP drive from CreateLinMotUdpDrive.
#include <chrono>

#include "adapters/linmot/linudp/factory.h"
#include "adapters/linmot/mc/error_codes.h"
#include "adapters/linmot/mc/warn_word.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/server.h"
#include "tests/contract/family_fixture.h"

namespace drivegw::contract {
namespace {

using namespace std::chrono_literals;

class LinMotUdpFixture final : public FamilyFixture {
 public:
  absl::Status Start(DriveRegistry& registry) override {
    sim::linmot::SimOptions o;
    o.name = "contract-linmot";
    o.bind = transport::Endpoint{transport::Endpoint::kLoopback, 0};
    o.master_port = 0;  // answer the gateway's ephemeral port (ctest -j never collides)
    o.hw_test_time = 50ms;
    auto server = sim::linmot::LinMotServer::Start(o, SteadyClock::Instance());
    if (!server.ok()) return server.status();
    server_ = std::move(*server);
    registry.Register(linmot::linudp::kFamilyName, linmot::linudp::CreateLinMotUdpDrive);

    config_.name = "c1";
    config_.family = linmot::linudp::kFamilyName;
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 150;  // the simulator's default stroke
    config_.axis.max_velocity_mm_s = 1000;
    config_.axis.max_acceleration_mm_s2 = 20000;
    LinUdpConfig l;
    l.host = "127.0.0.1";
    l.port = server_->port();
    l.bind_host = "127.0.0.1";
    l.master_port = 0;
    l.cycle = 2ms;
    l.reply_timeout = 30ms;
    l.lost_after_timeouts = 3;
    config_.linudp = l;
    return absl::OkStatus();
  }
  DriveConfig config() const override { return config_; }
  void Stop() override {
    if (server_) server_->Stop();
  }

  absl::Status InjectFault(bool fatal) override {
    // linmot-mc.md §10: 0003h X1 Pwr Voltage Too Low (Err); 000Dh X1 Pwr Over Current (Fatal).
    return server_->RaiseError(fatal ? linmot::mc::kPwrOverCurrent : linmot::mc::kPwrVoltageTooLow);
  }
  absl::StatusOr<std::string> InjectWarning() override {
    server_->SetInjectedWarnings(linmot::mc::WarnWord::kMotorSupplyVoltageLow);
    return std::string(linmot::mc::WarnBitName(2));
  }
  absl::Status SetAnswering(bool answering) override {
    server_->SetAnswering(answering);
    return absl::OkStatus();
  }
  absl::StatusOr<ParameterRef> WritableParameter() const override {
    return ParameterRef{sim::linmot::upid::kPredefVelocity, false};
  }
  int64_t WritableParameterValue() const override { return 250000; }  // 0.25 m/s
  absl::StatusOr<ParameterRef> UnknownParameter() const override {
    return ParameterRef{0x7777, false};
  }

 private:
  std::unique_ptr<sim::linmot::LinMotServer> server_;
  DriveConfig config_;
};

}  // namespace

std::unique_ptr<FamilyFixture> MakeLinMotUdpFixture() {
  return std::make_unique<LinMotUdpFixture>();
}

}  // namespace drivegw::contract
