// Cross-check of decision 009: every catalogue id is a ParameterRef.id the family's drive
// accepts, against its simulator. Trinamic: the simulated SIXpack on a real pty (ReadParameter of
// every definition, WriteParameter of every default). STOBER: the simulated axis on the UDP
// multicast CAN bus (an SDO ReadParameter of every writable bound object). LinMot (LinUDP,
// DeviceNet) is not cross-checked here: the simulators hold only a subset of the documented UPIDs
// / the catalogue ids are the drive's own command table (decision 009).
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>

#include "adapters/core/clock.h"
#include "adapters/stober/factory.h"
#include "adapters/trinamic/factory.h"
#include "sim/stober/server.h"
#include "sim/trinamic/server.h"

namespace drivegw {
namespace {

using namespace std::chrono_literals;

DriveStatus WaitOnline(Drive* d) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  DriveStatus s = d->GetStatus();
  while (s.state == DriveState::kOffline && std::chrono::steady_clock::now() < deadline) {
    s = d->WaitForStatus(s.sequence, deadline);
  }
  return s;
}

uint16_t RandomPort() {
  static std::mt19937 rng(std::random_device{}() ^ static_cast<unsigned>(::getpid()));
  return static_cast<uint16_t>(20000 + rng() % 20001);
}

TEST(CatalogueAgainstDrive, TrinamicEveryIdReadableAndEveryDefaultWritable) {
  sim::trinamic::ServerOptions options;
  options.pty_path =
      (std::filesystem::temp_directory_path() / ("dgw-trcat-" + std::to_string(::getpid())))
          .string();
  auto server = sim::trinamic::TrinamicServer::Start(options, SteadyClock::Instance());
  ASSERT_TRUE(server.ok()) << server.status();

  DriveConfig c;
  c.name = "cat-x";
  c.family = trinamic::kFamilyName;
  c.axis.min_mm = -20000;
  c.axis.max_mm = 20000;
  c.axis.max_velocity_mm_s = 26000;
  c.axis.max_acceleration_mm_s2 = 120000;
  c.timeouts.request = 2000ms;
  TrinamicConfig t;
  t.address = 1;
  t.axis = 0;
  t.axes = 6;
  t.microsteps_per_unit = 1;
  t.poll_period = 5ms;
  t.reply_timeout = 60ms;
  t.offline_after_misses = 2;
  t.serial = SerialLineConfig{(*server)->slave_path(), 19200, false, 6000us};
  c.trinamic = t;
  auto drive = trinamic::CreateTrinamicDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(drive.ok()) << drive.status();
  ASSERT_TRUE((*drive)->Activate().ok());
  ASSERT_NE(WaitOnline(drive->get()).state, DriveState::kOffline);

  const auto cat = trinamic::TrinamicParameterCatalogue();
  for (const ParameterDefinition& d : cat->Definitions()) {
    auto v = (*drive)->ReadParameter(ParameterRef{d.id, false});
    ASSERT_TRUE(v.ok()) << d.name << ": " << v.status();
    EXPECT_TRUE(cat->Validate(d, *v).ok()) << d.name << " read " << *v;
    if (d.default_value) {
      // The PACK starts at the §5.12 defaults: writing them back must pass the drive's own
      // (cross-field) validation too.
      const absl::Status w = (*drive)->WriteParameter(ParameterRef{d.id, false}, *d.default_value);
      EXPECT_TRUE(w.ok()) << d.name << ": " << w;
    }
  }
  // And a value the catalogue refuses is refused by the drive too.
  auto vmax = cat->Find("$14.vmax");
  ASSERT_TRUE(vmax.ok());
  EXPECT_FALSE(cat->Validate(*vmax, vmax->max + 1).ok());
  EXPECT_FALSE((*drive)->WriteParameter(ParameterRef{vmax->id, false}, vmax->max + 1).ok());
  (*drive)->Deactivate();
  (*server)->Stop();
}

TEST(CatalogueAgainstDrive, StoberEveryWritableIdReadable) {
  CanBusConfig bus;
  bus.kind = CanBusConfig::Kind::kUdpMulticast;
  bus.group = "239.74.163.99";
  bus.port = RandomPort();
  sim::stober::AxisServerOptions o;
  o.node_id = 11;
  o.can = bus;
  auto server = sim::stober::AxisServer::Start(o, SteadyClock::Instance());
  ASSERT_TRUE(server.ok()) << server.status();

  DriveConfig c;
  c.name = "cat-st";
  c.family = stober::kFamilyName;
  c.can = bus;
  c.node_id = 11;
  c.axis.min_mm = -200;
  c.axis.max_mm = 200;
  c.axis.max_velocity_mm_s = 1000;
  c.axis.max_acceleration_mm_s2 = 10000;
  c.canopen.heartbeat = 50ms;
  c.canopen.heartbeat_timeout = 200ms;
  c.canopen.sdo_timeout = 300ms;
  auto drive = stober::CreateStoberDrive(c, SteadyClock::Instance());
  ASSERT_TRUE(drive.ok()) << drive.status();
  ASSERT_TRUE((*drive)->Activate().ok());
  ASSERT_NE(WaitOnline(drive->get()).state, DriveState::kOffline);

  const auto cat = stober::StoberParameterCatalogue();
  int checked = 0;
  for (const ParameterDefinition& d : cat->Definitions()) {
    if (!d.writable) continue;
    auto v = (*drive)->ReadParameter(ParameterRef{d.id, false});
    ASSERT_TRUE(v.ok()) << d.name << ": " << v.status();
    EXPECT_TRUE(cat->Validate(d, *v).ok()) << d.name << " read " << *v;
    ++checked;
  }
  EXPECT_GT(checked, 40);
  (*drive)->Deactivate();
  (*server)->Stop();
}

}  // namespace
}  // namespace drivegw
