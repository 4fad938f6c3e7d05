// Shared pieces of the service-core tests: a core over FakeDrives, and the google.rpc.BadRequest
// field a failed status names.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "google/rpc/error_details.pb.h"
#include "server/core/drive_service.h"
#include "server/core/errors.h"
#include "tests/server/core/fake_drive.h"

namespace drivegw::server::test_support {

// The first field violation of `s`'s BadRequest payload ("" when there is none).
inline std::string ViolationField(const absl::Status& s) {
  auto payload = s.GetPayload(absl::string_view(kBadRequestUrl.data(), kBadRequestUrl.size()));
  if (!payload) return "";
  google::rpc::BadRequest br;
  if (!br.ParseFromString(std::string(*payload)) || br.field_violations_size() == 0) return "";
  return br.field_violations(0).field();
}

// Drives by name; the core sees them in the order added.
class FakeFleet {
 public:
  FakeDrive& Add(std::string name, std::string family, bool interpolates) {
    return AddConfig(FakeDrive::Config(std::move(name), std::move(family)), interpolates);
  }
  FakeDrive& AddConfig(DriveConfig config, bool interpolates) {
    auto d = std::make_shared<FakeDrive>(std::move(config), interpolates);
    drives_.push_back(d);
    return *d;
  }
  std::vector<std::shared_ptr<Drive>> drives() const { return drives_; }

 private:
  std::vector<std::shared_ptr<Drive>> drives_;
};

}  // namespace drivegw::server::test_support
