// The seam of the contract suite: one FamilyFixture per drive family starts that family's
// simulator on real sockets and hands out the Drive through the family's factory.
#pragma once

#include <functional>
#include <ostream>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "adapters/core/clock.h"
#include "adapters/core/drive.h"
#include "adapters/core/registry.h"

namespace drivegw::contract {

// What the contract needs from a family. Hooks a family cannot offer return Unimplemented; the
// case that needs it is then skipped for that family (and says so), never passed silently.
class FamilyFixture {
 public:
  virtual ~FamilyFixture() = default;

  // Starts the simulator (real sockets, ephemeral ports) and registers the family's factory;
  // the config returned makes DriveRegistry::Create build a drive talking to that simulator.
  virtual absl::Status Start(DriveRegistry& registry) = 0;
  virtual DriveConfig config() const = 0;
  // Stops the simulator; idempotent. The drive is deactivated before this is called.
  virtual void Stop() = 0;

  // A drive error the operator can acknowledge (recoverable) or not (fatal).
  virtual absl::Status InjectFault(bool fatal) = 0;
  // A warning condition; returns the name the drive reports in DriveStatus.warnings.
  virtual absl::StatusOr<std::string> InjectWarning() = 0;
  // Simulated cable cut: the drive stops answering (false) or answers again (true).
  virtual absl::Status SetAnswering(bool answering) = 0;
  // A parameter that exists, is writable in RAM and ROM, and accepts `value`.
  virtual absl::StatusOr<ParameterRef> WritableParameter() const = 0;
  virtual int64_t WritableParameterValue() const = 0;
  // A parameter id the drive does not know.
  virtual absl::StatusOr<ParameterRef> UnknownParameter() const = 0;

  // Smallest position step the family's wire carries; tolerances are never tighter (0: finer
  // than any tolerance of the suite).
  virtual double PositionResolutionMm() const { return 0; }
  // False for families without stored (ROM) values: writing one must then fail, not go to RAM.
  virtual bool HasStoredParameters() const { return true; }
  // False when a link loss takes the drive out of operation and the gateway, by design, does not
  // re-enable it on reconnect (no replay, e.g. linmot-devicenet decision 983).
  virtual bool EnabledAcrossLinkLoss() const { return true; }
};

struct FamilyCase {
  std::string name;  // test name suffix: "linmot"
  std::function<std::unique_ptr<FamilyFixture>()> make;
};
// gtest prints the parameter by this (otherwise as raw bytes in every test name ctest shows).
inline void PrintTo(const FamilyCase& c, std::ostream* os) { *os << c.name; }

// Families under contract (one line per family, defined next to each fixture).
std::unique_ptr<FamilyFixture> MakeLinMotUdpFixture();
std::unique_ptr<FamilyFixture> MakeLinMotDnFixture();
std::unique_ptr<FamilyFixture> MakeTrinamicFixture();
std::unique_ptr<FamilyFixture> MakeStoberFixture();

}  // namespace drivegw::contract
