// A Drive test double for the curve API: records the curves it was asked to download and run, and
// answers like a family with or without curve storage (DownloadCurve) and a curve runner
// (RunCurve); without them it keeps the seam's Unimplemented defaults (decision 013).
#pragma once

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "adapters/core/drive.h"

namespace drivegw::server::test_support {

class CurveDrive final : public Drive {
 public:
  // An axis 0..100 mm, 500 mm/s, 5000 mm/s².
  CurveDrive(std::string name, std::string family, bool stores_curves, bool runs_curves)
      : stores_curves_(stores_curves), runs_curves_(runs_curves) {
    config_.name = std::move(name);
    config_.family = std::move(family);
    config_.axis.min_mm = 0;
    config_.axis.max_mm = 100;
    config_.axis.max_velocity_mm_s = 500;
    config_.axis.max_acceleration_mm_s2 = 5000;
  }

  struct Run {
    Curve curve;
    CurveRunOptions options;
  };
  std::vector<LinMotParametricCurve> downloads() const {
    std::lock_guard lock(mu_);
    return downloads_;
  }
  std::vector<Run> runs() const {
    std::lock_guard lock(mu_);
    return runs_;
  }
  // The next download/run fails with this status (e.g. a read-back mismatch, a start position).
  void FailNext(absl::Status s) {
    std::lock_guard lock(mu_);
    fail_next_ = std::move(s);
  }
  // The health GetStatus reports (default none, as for a family without supervision).
  void SetHealthInfo(std::optional<HealthInfo> health) {
    std::lock_guard lock(mu_);
    health_ = std::move(health);
  }

  absl::Status DownloadCurve(const LinMotParametricCurve& curve) override {
    if (!stores_curves_) return Drive::DownloadCurve(curve);
    std::lock_guard lock(mu_);
    if (fail_next_) return *std::exchange(fail_next_, std::nullopt);
    downloads_.push_back(curve);
    return absl::OkStatus();
  }
  absl::StatusOr<CommandInfo> RunCurve(const Curve& curve,
                                       const CurveRunOptions& options) override {
    if (!runs_curves_) return Drive::RunCurve(curve, options);
    std::lock_guard lock(mu_);
    if (fail_next_) return *std::exchange(fail_next_, std::nullopt);
    runs_.push_back({curve, options});
    CommandInfo info;
    info.id = 40 + runs_.size();
    info.kind = "RunCurve";
    info.state = CommandState::kActive;
    info.progress = 0.0;
    return info;
  }

  const DriveConfig& config() const override { return config_; }
  std::string endpoint() const override { return "curve://" + config_.name; }
  absl::Status Activate() override { return absl::OkStatus(); }
  void Deactivate() override {}
  Lifecycle lifecycle() const override { return Lifecycle::kActive; }
  absl::StatusOr<CommandInfo> Enable() override { return absl::UnimplementedError("fake"); }
  absl::StatusOr<CommandInfo> Disable() override { return absl::UnimplementedError("fake"); }
  absl::StatusOr<CommandInfo> Home() override { return absl::UnimplementedError("fake"); }
  absl::StatusOr<CommandInfo> Move(const MotionCommand&) override {
    return absl::UnimplementedError("fake");
  }
  absl::StatusOr<CommandInfo> AcknowledgeFault() override {
    return absl::UnimplementedError("fake");
  }
  absl::StatusOr<int64_t> ReadParameter(const ParameterRef&) override {
    return absl::UnimplementedError("fake");
  }
  absl::Status WriteParameter(const ParameterRef&, int64_t) override {
    return absl::UnimplementedError("fake");
  }
  absl::StatusOr<NativeReply> SendNative(const NativeRequest&) override {
    return absl::UnimplementedError("fake");
  }
  DriveStatus GetStatus() const override {
    std::lock_guard lock(mu_);
    DriveStatus s;
    s.health = health_;
    return s;
  }
  std::optional<CommandInfo> GetCommand(uint64_t) const override { return std::nullopt; }
  DriveStatus WaitForStatus(uint64_t, std::chrono::steady_clock::time_point) const override {
    return DriveStatus{};
  }

 private:
  DriveConfig config_;
  const bool stores_curves_;
  const bool runs_curves_;
  mutable std::mutex mu_;
  std::vector<LinMotParametricCurve> downloads_;
  std::vector<Run> runs_;
  std::optional<absl::Status> fail_next_;
  std::optional<HealthInfo> health_;
};

}  // namespace drivegw::server::test_support
