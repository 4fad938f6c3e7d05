// A Drive test double for the service core: fixed answers, and a record of what the core handed
// it (native requests, parameter ids, coordinated moves with their group, cyclic set points).
// Families are plain strings; `interpolates` false keeps Drive::MoveCoordinated's default
// (UNIMPLEMENTED), as every family without a coordinated move does; likewise StartCyclic keeps the
// default until SetCyclic(true).
#pragma once

#include <algorithm>
#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "adapters/core/drive.h"

namespace drivegw::server::test_support {

// What the fake cyclic stream saw; shared with the stream, so it outlives it.
struct CyclicRecord {
  CyclicMode mode = CyclicMode::kPosition;
  std::vector<CyclicSetpoint> setpoints;
  int closes = 0;               // Close() calls
  bool destroyed_open = false;  // destroyed without Close (the seam closes it then)
};

// Pushes are recorded; stats report every set point as received, `late` of them as late (not
// sent), and `missing` cycles, on a 2 ms cycle. Push number `fail_at` (0-based) fails as a drive
// fault would.
class FakeCyclicStream final : public Drive::CyclicStream {
 public:
  struct Options {
    uint64_t late = 0;
    uint64_t missing = 0;
    std::optional<size_t> fail_at;
  };
  FakeCyclicStream(std::shared_ptr<std::mutex> mu, std::shared_ptr<CyclicRecord> record,
                   Options options, CyclicMode mode)
      : mu_(std::move(mu)), record_(std::move(record)), options_(options) {
    info_.id = 7;
    info_.kind = mode == CyclicMode::kPosition ? "CyclicPosition" : "CyclicSpeed";
    info_.state = CommandState::kActive;
  }
  ~FakeCyclicStream() override {
    std::lock_guard lock(*mu_);
    if (record_->closes == 0) record_->destroyed_open = true;
  }
  const CommandInfo& command() const override { return info_; }
  absl::Status Push(const CyclicSetpoint& setpoint) override {
    std::lock_guard lock(*mu_);
    if (options_.fail_at && record_->setpoints.size() == *options_.fail_at) {
      return absl::FailedPreconditionError("drive 'fake': following error, cyclic command ended");
    }
    record_->setpoints.push_back(setpoint);
    return absl::OkStatus();
  }
  CyclicStats stats() const override {
    std::lock_guard lock(*mu_);
    CyclicStats s;
    s.received = record_->setpoints.size();
    s.late = std::min<uint64_t>(options_.late, s.received);
    s.sent = s.received - s.late;
    s.missing = options_.missing;
    s.cycle = std::chrono::microseconds(2000);
    return s;
  }
  absl::StatusOr<CommandInfo> Close() override {
    std::lock_guard lock(*mu_);
    ++record_->closes;
    info_.state = CommandState::kDone;
    info_.ended = std::chrono::system_clock::now();
    return info_;
  }

 private:
  std::shared_ptr<std::mutex> mu_;
  std::shared_ptr<CyclicRecord> record_;
  const Options options_;
  CommandInfo info_;
};

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

  // StartCyclic answers a FakeCyclicStream (false: the seam's UNIMPLEMENTED default).
  void SetCyclic(bool supported, FakeCyclicStream::Options options = {}) {
    std::lock_guard lock(mu_);
    cyclic_ = supported;
    cyclic_options_ = options;
  }
  // The record of the last cyclic stream started (nullopt: none).
  std::optional<CyclicRecord> cyclic() const {
    std::lock_guard lock(*cyclic_mu_);
    if (!cyclic_record_) return std::nullopt;
    return *cyclic_record_;
  }
  // The unified state GetStatus reports (default OFFLINE); each call publishes a new snapshot
  // (sequence + 1), as a drive's status cycle does.
  void SetState(DriveState state) {
    std::lock_guard lock(mu_);
    state_ = state;
    ++sequence_;
  }
  // The health GetStatus reports (default none, as for a family without supervision).
  void SetHealthInfo(std::optional<HealthInfo> health) {
    std::lock_guard lock(mu_);
    health_ = std::move(health);
    ++sequence_;
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
    {
      std::lock_guard lock(mu_);
      ++moves_;
    }
    return Done(KindName(cmd));
  }
  // Move calls that reached the drive.
  int moves() const {
    std::lock_guard lock(mu_);
    return moves_;
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

  absl::StatusOr<std::unique_ptr<CyclicStream>> StartCyclic(CyclicMode mode) override {
    FakeCyclicStream::Options options;
    {
      std::lock_guard lock(mu_);
      if (!cyclic_) return Drive::StartCyclic(mode);
      ++calls_;
      options = cyclic_options_;
    }
    auto record = std::make_shared<CyclicRecord>();
    record->mode = mode;
    {
      std::lock_guard lock(*cyclic_mu_);
      cyclic_record_ = record;
    }
    return std::make_unique<FakeCyclicStream>(cyclic_mu_, std::move(record), options, mode);
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

  DriveStatus GetStatus() const override {
    std::lock_guard lock(mu_);
    DriveStatus s;
    s.state = state_;
    s.sequence = sequence_;
    s.health = health_;
    return s;
  }
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
  DriveState state_ = DriveState::kOffline;
  std::optional<HealthInfo> health_;
  int moves_ = 0;
  uint64_t sequence_ = 0;
  bool cyclic_ = false;
  FakeCyclicStream::Options cyclic_options_;
  // Shared with the streams (their Push may run on a gRPC thread while the test reads).
  std::shared_ptr<std::mutex> cyclic_mu_ = std::make_shared<std::mutex>();
  std::shared_ptr<CyclicRecord> cyclic_record_;
};

}  // namespace drivegw::server::test_support
