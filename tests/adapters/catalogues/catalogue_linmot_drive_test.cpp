// Cross-check of decision 009 for the LinMot families against their simulators. LinUDP: the
// simulator holds only a subset of the documented UPIDs (sim/linmot/parameters.h), so every
// catalogue UPID the simulator knows must be readable (RAM, and ROM where the catalogue says it
// has a stored value) and its simulated range must lie inside the catalogue's. DeviceNet: every
// catalogue id (a Set command) is readable through its Get half and its current value writable.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <memory>

#include "adapters/core/clock.h"
#include "adapters/linmot/devicenet/commands.h"
#include "adapters/linmot/devicenet/drive.h"
#include "adapters/linmot/devicenet/factory.h"
#include "adapters/linmot/linudp/factory.h"
#include "sim/linmot/parameters.h"
#include "sim/linmot/server.h"
#include "sim/linmot_devicenet/server.h"
#include "tests/support/linudp_bench.h"

namespace drivegw {
namespace {

using namespace std::chrono_literals;

DriveStatus WaitOnline(Drive& d) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  DriveStatus s = d.GetStatus();
  while (s.state == DriveState::kOffline && std::chrono::steady_clock::now() < deadline) {
    s = d.WaitForStatus(s.sequence, deadline);
  }
  return s;
}

TEST(CatalogueAgainstDrive, LinMotUpidsTheSimulatorKnowsAreReadable) {
  sim::linmot::SimOptions o = test_support::LinUdpSimOptions();
  auto server = sim::linmot::LinMotServer::Start(o, SteadyClock::Instance());
  ASSERT_TRUE(server.ok()) << server.status();
  DriveConfig c = test_support::LinUdpDriveConfig((*server)->port());
  c.name = "cat-lm";
  c.family = linmot::linudp::kFamilyName;
  auto drive = linmot::linudp::CreateLinMotUdpDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(drive.ok()) << drive.status();
  ASSERT_TRUE((*drive)->Activate().ok());
  ASSERT_NE(WaitOnline(**drive).state, DriveState::kOffline);

  const auto sim_table = sim::linmot::Parameters::ForOptions(o);
  const auto cat = linmot::linudp::LinMotParameterCatalogue();
  int known = 0;
  for (const ParameterDefinition& d : cat->Definitions()) {
    const sim::linmot::ParamDef* s = sim_table.Find(static_cast<uint16_t>(d.id));
    if (s == nullptr) continue;
    ++known;
    auto ram = (*drive)->ReadParameter(ParameterRef{d.id, false});
    ASSERT_TRUE(ram.ok()) << d.name << ": " << ram.status();
    EXPECT_GE(s->min, d.min) << d.name;
    EXPECT_LE(s->max, d.max) << d.name;
    EXPECT_EQ(d.writable, !s->read_only) << d.name;
    if (d.has_stored_value) {
      auto rom = (*drive)->ReadParameter(ParameterRef{d.id, true});
      EXPECT_TRUE(rom.ok()) << d.name << " ROM: " << rom.status();
    }
  }
  EXPECT_GE(known, 20);
  (*drive)->Deactivate();
}

TEST(CatalogueAgainstDrive, LinMotDevicenetEveryPairReadableAndWritable) {
  static std::atomic<int> next{0};
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.98";
  bus.port = static_cast<uint16_t>(20000 + (::getpid() * 16 + 7 + next++) % 40000);
  sim::linmot_devicenet::DnSimOptions o;
  o.duplicate_check_wait = 50ms;
  o.can = bus;
  auto server = sim::linmot_devicenet::LinMotDnServer::Start(o, SteadyClock::Instance());
  ASSERT_TRUE(server.ok()) << server.status();
  DriveConfig c;
  c.name = "cat-dn";
  c.family = linmot::devicenet::kFamilyName;
  c.axis.min_mm = 0;
  c.axis.max_mm = 150;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 20000;
  c.can = bus;
  c.mac_id = o.mac_id;
  linmot::devicenet::DnDriveOptions options;
  options.session.duplicate_check_wait = 50ms;
  options.restart_wait = 150ms;
  auto drive =
      std::make_unique<linmot::devicenet::LinMotDnDrive>(c, SteadyClock::Instance(), options);
  ASSERT_TRUE(drive->Activate().ok());
  ASSERT_NE(WaitOnline(*drive).state, DriveState::kOffline);

  const auto cat = linmot::devicenet::LinMotDevicenetParameterCatalogue();
  int module_refusals = 0;
  for (const ParameterDefinition& d : cat->Definitions()) {
    auto v = drive->ReadParameter(ParameterRef{d.id, false});
    const linmot::devicenet::CommandSpec* spec =
        linmot::devicenet::FindCommand(static_cast<uint8_t>(d.id));
    ASSERT_NE(spec, nullptr) << d.name;
    if (spec->requirement != linmot::devicenet::Requirement::kNone) {
      // Needs a master encoder / IO module the simulated controller lacks: the id is accepted and
      // sent, the drive refuses it by its configuration (coded error 0x8120, §8.6).
      if (!v.ok()) {
        EXPECT_EQ(v.status().code(), absl::StatusCode::kFailedPrecondition) << v.status();
        ++module_refusals;
        continue;
      }
    }
    ASSERT_TRUE(v.ok()) << d.name << ": " << v.status();
    EXPECT_TRUE(cat->Validate(d, *v).ok()) << d.name << " read " << *v;
    const absl::Status w = drive->WriteParameter(ParameterRef{d.id, false}, *v);
    EXPECT_TRUE(w.ok()) << d.name << ": " << w;
  }
  EXPECT_LT(module_refusals, 8);  // only the module-dependent pairs (0x63, 0x67, 0x6B, 0x71, 0x73)
  drive->Deactivate();
  (*server)->Stop();
}

}  // namespace
}  // namespace drivegw
