// A Drive test double for the service core: fixed answers, and a record of what the core handed
// it (native requests, parameter ids, coordinated moves with their group). Families are plain
// strings; `interpolates` false keeps Drive::MoveCoordinated's default (UNIMPLEMENTED), as every
// family without a coordinated move does.
#pragma once

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "adapters/core/drive.h"

namespace drivegw::server::test_support {

class FakeDrive final : public Drive {
 public:
  FakeDrive(DriveConfig config, bool interpolates)
      : config_(std::move(config)), interpolates_(interpolates) {}

  // A drive named `name` of `family` on an axis 0..100 mm, 500 mm/s, 5000 mm/s².
  static DriveConfig Config(std::string name, std::string family) {
    DriveConfig c;
    c.name = std::move(name);
    c.family = std::move(family);
    c.axis.min_mm = 0;
    c.axis.max_mm = 100;
    c.axis.max_velocity_mm_s = 500;
    c.axis.max_acceleration_mm_s2 = 5000;
    return c;
  }

  struct CoordinatedCall {
    CoordinatedMove move;
    std::vector<std::string> group;  // config names, in the order the core passed them
  };

  // What the next SendNative answers.
  void SetNativeReply(NativeReply reply) {
    std::lock_guard lock(mu_);
    reply_ = std::move(reply);
  }
  // Answers MoveCoordinated with this many handles instead of one per member (a broken family).
  void SetHandleCount(size_t n) {
    std::lock_guard lock(mu_);
    handle_count_ = n;
  }
  std::optional<CoordinatedCall> coordinated() const {
    std::lock_guard lock(mu_);
    return coordinated_;
  }
  std::optional<NativeRequest> native() const {
    std::lock_guard lock(mu_);
    return native_;
  }
  std::optional<uint32_t> parameter_id() const {
    std::lock_guard lock(mu_);
    return parameter_id_;
  }
  int calls() const {
    std::lock_guard lock(mu_);
    return calls_;
  }

  const DriveConfig& config() const override { return config_; }
  std::string endpoint() const override { return "fake://" + config_.name; }
  absl::Status Activate() override { return absl::OkStatus(); }
  void Deactivate() override {}
  Lifecycle lifecycle() const override { return Lifecycle::kActive; }

  absl::StatusOr<CommandInfo> Enable() override { return Done("Enable"); }
  absl::StatusOr<CommandInfo> Disable() override { return Done("Disable"); }
  absl::StatusOr<CommandInfo> Home() override { return Done("Home"); }
  absl::StatusOr<CommandInfo> Move(const MotionCommand& cmd) override {
    return Done(KindName(cmd));
  }
  absl::StatusOr<CommandInfo> AcknowledgeFault() override { return Done("AcknowledgeFault"); }

  absl::StatusOr<std::vector<CommandInfo>> MoveCoordinated(const CoordinatedMove& move,
                                                           std::span<Drive* const> group) override {
    if (!interpolates_) return Drive::MoveCoordinated(move, group);
    std::lock_guard lock(mu_);
    ++calls_;
    CoordinatedCall call{move, {}};
    for (Drive* d : group) call.group.push_back(d->config().name);
    coordinated_ = std::move(call);
    // Ids 100, 101, ... in group order, so a test sees which handle went to which drive.
    std::vector<CommandInfo> out;
    const size_t n = handle_count_.value_or(group.size());
    for (size_t i = 0; i < n; ++i) {
      CommandInfo info;
      info.id = 100 + i;
      info.kind = "MoveCoordinated";
      info.state = CommandState::kActive;
      out.push_back(std::move(info));
    }
    return out;
  }

  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override {
    std::lock_guard lock(mu_);
    parameter_id_ = ref.id;
    return 42;
  }
  absl::Status WriteParameter(const ParameterRef& ref, int64_t) override {
    std::lock_guard lock(mu_);
    parameter_id_ = ref.id;
    return absl::OkStatus();
  }
  absl::StatusOr<NativeReply> SendNative(const NativeRequest& req) override {
    std::lock_guard lock(mu_);
    ++calls_;
    native_ = req;
    return reply_;
  }

  DriveStatus GetStatus() const override { return DriveStatus{}; }
  std::optional<CommandInfo> GetCommand(uint64_t) const override { return std::nullopt; }
  DriveStatus WaitForStatus(uint64_t, std::chrono::steady_clock::time_point) const override {
    return DriveStatus{};
  }

 private:
  static CommandInfo Done(std::string kind) {
    CommandInfo info;
    info.id = 1;
    info.kind = std::move(kind);
    info.state = CommandState::kDone;
    return info;
  }

  const DriveConfig config_;
  const bool interpolates_;
  mutable std::mutex mu_;
  NativeReply reply_;
  std::optional<size_t> handle_count_;
  std::optional<CoordinatedCall> coordinated_;
  std::optional<NativeRequest> native_;
  std::optional<uint32_t> parameter_id_;
  int calls_ = 0;
};

}  // namespace drivegw::server::test_support
