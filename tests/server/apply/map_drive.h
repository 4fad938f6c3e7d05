// A Drive test double whose parameters live in a map, with fault injection at the k-th write
// (the drive refuses it), a read-back mismatch at the k-th write (the drive keeps another value),
// and refused restores (writes after the first failure), to drive every branch of the apply.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/core/drive.h"

namespace drivegw::server::test_support {

class MapDrive final : public Drive {
 public:
  MapDrive(std::string name, std::string family, std::map<uint32_t, int64_t> values)
      : values_(std::move(values)) {
    config_.name = std::move(name);
    config_.family = std::move(family);
  }

  struct Faults {
    std::optional<int> refuse_write;      // write number k (0-based) is refused, nothing stored
    std::optional<int> mismatch;          // write number k stores value + 7 (read back differs)
    bool refuse_after_failure = false;    // every write after the injected one is refused
    std::optional<uint32_t> refuse_read;  // reading this id fails
  };
  void SetFaults(Faults f) {
    std::lock_guard lock(mu_);
    faults_ = f;
  }
  int64_t Value(uint32_t id, bool rom = false) const {
    std::lock_guard lock(mu_);
    const auto& m = rom ? rom_ : values_;
    auto it = m.find(id);
    return it == m.end() ? 0 : it->second;
  }
  void SetRom(uint32_t id, int64_t v) {
    std::lock_guard lock(mu_);
    rom_[id] = v;
  }
  // Every write the drive took (id, value, rom), in order.
  std::vector<std::pair<uint32_t, int64_t>> writes() const {
    std::lock_guard lock(mu_);
    return writes_;
  }
  int write_calls() const {
    std::lock_guard lock(mu_);
    return calls_;
  }

  const DriveConfig& config() const override { return config_; }
  std::string endpoint() const override { return "map://" + config_.name; }
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
  absl::StatusOr<NativeReply> SendNative(const NativeRequest&) override {
    return absl::UnimplementedError("fake");
  }

  // Called before every read, outside the drive's lock (tests look at the stored operation).
  std::function<void()> before_read;

  absl::StatusOr<int64_t> ReadParameter(const ParameterRef& ref) override {
    if (before_read) before_read();
    std::lock_guard lock(mu_);
    if (faults_.refuse_read && *faults_.refuse_read == ref.id) {
      return absl::UnavailableError(
          absl::StrCat("drive '", config_.name, "': no answer reading ", std::to_string(ref.id)));
    }
    const auto& m = ref.rom ? rom_ : values_;
    auto it = m.find(ref.id);
    if (it == m.end()) {
      return absl::NotFoundError(absl::StrCat("unknown parameter ", std::to_string(ref.id)));
    }
    return it->second;
  }
  // Called before every write, outside the drive's lock (decision 1441: what is stored by then).
  std::function<void()> before_write;

  absl::Status WriteParameter(const ParameterRef& ref, int64_t value) override {
    if (before_write) before_write();
    std::lock_guard lock(mu_);
    const int k = calls_++;
    if (failed_ && faults_.refuse_after_failure) {
      return absl::UnavailableError(absl::StrCat("drive '", config_.name, "': offline"));
    }
    if (faults_.refuse_write && *faults_.refuse_write == k) {
      failed_ = true;
      return absl::FailedPreconditionError(
          absl::StrCat("drive '", config_.name, "': refused ", std::to_string(ref.id)));
    }
    if (faults_.mismatch && *faults_.mismatch == k) {
      failed_ = true;
      value += 7;
    }
    (ref.rom ? rom_ : values_)[ref.id] = value;
    writes_.emplace_back(ref.id, value);
    return absl::OkStatus();
  }

  DriveStatus GetStatus() const override { return {}; }
  std::optional<CommandInfo> GetCommand(uint64_t) const override { return std::nullopt; }
  DriveStatus WaitForStatus(uint64_t, std::chrono::steady_clock::time_point) const override {
    return {};
  }

 private:
  DriveConfig config_;
  mutable std::mutex mu_;
  std::map<uint32_t, int64_t> values_;
  std::map<uint32_t, int64_t> rom_;
  Faults faults_;
  int calls_ = 0;
  bool failed_ = false;
  std::vector<std::pair<uint32_t, int64_t>> writes_;
};

}  // namespace drivegw::server::test_support
