// Issue 11 gap 11, STOBER part (decision 1483): a killed gateway must not leave a STOBER axis
// moving. `drivegw-sim stober` and the real `drivegw` run as separate processes on a user-space
// CAN bus of this run's own; over REST the axis is enabled and sent on a long move; then the
// gateway gets SIGKILL. The drive consumes the gateway's heartbeat (1016h:01, written by
// Configure) and reacts per 6007h = 3: quick stop, Switch on disabled. The test reads the axis
// by SDO through its own CANopen master (which produces no heartbeat): the actual position I80
// must stop changing within the consumer time plus the braking time (plus a stated margin for
// process scheduling on a loaded host) and stay put; the simulator's motion log names the
// reaction. Without the watchdog the axis would travel on for 40 s.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "adapters/canopen/master.h"
#include "adapters/stober/object_map.h"
#include "tests/e2e/child_process.h"
#include "tests/e2e/http_client.h"
#include "tests/reliability/gateway_process.h"

namespace drivegw::testing {
namespace {

using namespace std::chrono_literals;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;
using test_support::ChildProcess;
namespace co = drivegw::canopen;
namespace so = drivegw::stober;

constexpr auto kDeadline = 30s;
constexpr int kNode = 3;
constexpr int kHeartbeatMs = 50;           // the gateway's own heartbeat period
constexpr int kConsumerMs = 300;           // the drive's consumer time (heartbeat_timeout_ms)
constexpr double kVelocity = 200;          // mm/s
constexpr double kQuickStopDecel = 10000;  // I11 at power-on, u/s² (sim/stober/parameters.cpp)
// Process scheduling, the SDO exchanges of this test and the 1 ms A150 cycle on a host shared by
// several builds: the reaction may be seen this much later than the ideal bound.
constexpr auto kSchedulingMargin = 700ms;

class StoberWatchdogProcessTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-stober-wd-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    std::random_device rd;
    bus_.kind = CanBusConfig::Kind::kUdpMulticast;
    bus_.group = "239.74.164." + std::to_string(10 + rd() % 200);
    bus_.port = static_cast<uint16_t>(20000 + rd() % 40000);
    const std::string spec = "udp:" + bus_.group + ":" + std::to_string(bus_.port);

    sim_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{DGW_SIM_BIN, "stober", "--can", spec, "--node",
                                 std::to_string(kNode)},
        dir_ + "/sim.log");
    ASSERT_TRUE(sim_->started()) << "posix_spawn error " << sim_->spawn_error();
    ASSERT_TRUE(Eventually(
        [&] { return sim_->log().find("stober node") != std::string::npos || !sim_->Running(); },
        kDeadline))
        << sim_->Describe();

    const std::string config = dir_ + "/drivegw.yaml";
    std::ofstream(config) << "listen: {grpc: '127.0.0.1:0', http: '127.0.0.1:0'}\n"
                          << "data_dir: " << dir_ << "/data\n"
                          << "drives:\n"
                          << "  - name: s1\n"
                          << "    family: stober\n"
                          << "    can: {udp: {group: " << bus_.group << ", port: " << bus_.port
                          << "}}\n"
                          << "    node_id: " << kNode << "\n"
                          << "    canopen: {heartbeat_ms: " << kHeartbeatMs
                          << ", heartbeat_timeout_ms: " << kConsumerMs
                          << ", sdo_timeout_ms: 1000}\n"
                          << "    timeouts: {request_ms: 10000, accept_ms: 2000}\n"
                          << "    axis: {min_mm: -10000, max_mm: 10000, max_velocity_mm_s: 1000, "
                          << "max_acceleration_mm_s2: 10000}\n";
    gateway_ = std::make_unique<GatewayProcess>(DGW_GATEWAY_BIN, config, dir_ + "/drivegw.log");
    ASSERT_TRUE(gateway_->started());
    http_port_ = gateway_->WaitForHttpPort(kDeadline);
    ASSERT_GT(http_port_, 0) << gateway_->Log();
  }

  void TearDown() override {
    if (master_) master_->Stop();
    gateway_.reset();
    sim_.reset();
    if (HasFailure()) {
      std::cout << "--- drivegw-sim output:\n"
                << test_support::Tail(test_support::ReadWholeFile(dir_ + "/sim.log"))
                << "\n--- drivegw output:\n"
                << test_support::Tail(test_support::ReadWholeFile(dir_ + "/drivegw.log"), 6000)
                << std::endl;
    }
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  std::pair<int, Json> Call(const std::string& method, const std::string& target,
                            const std::string& body = "") {
    const HttpResponse r = HttpRequest(http_port_, method, target, body);
    last_body_ = r.body;
    return {r.status, Json::parse(r.body, nullptr, false)};
  }
  Json Status() {
    auto [status, j] = Call("GET", "/v1/drives/s1");
    return status == 200 && j.is_object() ? j["status"] : Json();
  }
  // The axis itself, by SDO (the gateway is dead by then): I80 actual position in u = mm.
  std::optional<double> SdoPosition() {
    auto b = so::FindBinding(so::P("I80"));
    if (!b.ok()) return std::nullopt;
    auto bytes = master_->Upload(kNode, b->address.index, b->address.sub_index,
                                 SteadyClock::Instance().Now() + 1s);
    if (!bytes.ok()) return std::nullopt;
    auto v = so::Decode(*b, *bytes);
    return v.ok() ? std::optional<double>(*v) : std::nullopt;
  }

  std::string dir_;
  CanBusConfig bus_;
  std::unique_ptr<ChildProcess> sim_;
  std::unique_ptr<GatewayProcess> gateway_;
  std::shared_ptr<co::CanopenMaster> master_;
  int http_port_ = 0;
  std::string last_body_;
};

TEST_F(StoberWatchdogProcessTest, GatewayKilledMidMove_AxisQuickStopsAndStaysStopped) {
  auto dead = [&] { return !gateway_->Running() || !sim_->Running(); };
  ASSERT_TRUE(Eventually(
      [&] {
        const std::string s = Status().is_object() ? Status().value("state", "") : "";
        return (!s.empty() && s != "OFFLINE" && s != "DRIVE_STATE_UNSPECIFIED") || dead();
      },
      kDeadline))
      << last_body_;
  auto [en_status, en] = Call("POST", "/v1/drives/s1:enable", "{}");
  ASSERT_EQ(en_status, 200) << last_body_;
  ASSERT_EQ(en.value("state", ""), "DONE") << last_body_;
  // 9000 mm at 200 mm/s: 45 s of travel.
  auto [mv_status, mv] =
      Call("POST", "/v1/drives/s1:moveAbsolute",
           R"({"position_mm": 9000, "velocity_mm_s": 200, "acceleration_mm_s2": 1000})");
  ASSERT_EQ(mv_status, 200) << last_body_;
  double before_kill = 0;
  ASSERT_TRUE(Eventually(
      [&] {
        const Json s = Status();
        before_kill = s.is_object() ? s.value("position_mm", 0.0) : 0.0;
        return before_kill > 20 || dead();
      },
      kDeadline))
      << "the axis did not move: " << last_body_;
  ASSERT_GT(before_kill, 20) << "the axis did not move: " << last_body_;
  ASSERT_TRUE(gateway_->Running() && sim_->Running()) << gateway_->Log() << sim_->Describe();

  const auto killed_at = Clock::now();
  gateway_->Kill();  // SIGKILL: no shutdown code runs, the last move stays commanded
  ASSERT_FALSE(gateway_->Running());

  // A master of the test's own on the bus (produces no heartbeat), for SDO reads of the axis.
  auto m = co::CanopenMaster::Open(bus_);
  ASSERT_TRUE(m.ok()) << m.status();
  master_ = *std::move(m);
  // Stopped: two reads 200 ms apart agree. Within the consumer time, the braking time and the
  // scheduling margin the axis must have been seen at rest.
  const auto braking =
      std::chrono::milliseconds(static_cast<int>(std::ceil(1000 * kVelocity / kQuickStopDecel)));
  const auto bound = std::chrono::milliseconds(kConsumerMs) + braking + kSchedulingMargin;
  std::optional<double> previous;
  std::optional<Clock::time_point> rest_since;
  double rest_position = 0;
  while (Clock::now() - killed_at < 10s) {
    const std::optional<double> p = SdoPosition();
    if (p && previous && *p == *previous) {
      rest_position = *p;
      break;
    }
    if (p) rest_since = Clock::now();
    previous = p;
    std::this_thread::sleep_for(200ms);
  }
  ASSERT_TRUE(rest_since.has_value()) << "no SDO answer from the axis";
  ASSERT_NE(rest_position, 0) << "the axis never came to rest within 10 s of the kill (last "
                              << (previous ? *previous : -1) << " mm)";
  // The first read of the agreeing pair was taken at rest; the stop happened before it.
  const auto stopped_after =
      std::chrono::duration_cast<std::chrono::milliseconds>(*rest_since - killed_at);
  std::cout << "axis at rest " << stopped_after.count() << " ms after SIGKILL at " << rest_position
            << " mm (" << rest_position - before_kill << " mm after the last REST position); bound "
            << bound.count() << " ms" << std::endl;
  EXPECT_LE(stopped_after, bound);
  EXPECT_LE(rest_position - before_kill, kVelocity * std::chrono::duration<double>(bound).count());
  EXPECT_LT(rest_position, 9000);

  // And it stays put: no move resumes, the drive is Switch on disabled (6041h x1xx 0000,
  // CiA 402), so a later gateway must enable it again on purpose.
  std::this_thread::sleep_for(1s);
  const std::optional<double> later = SdoPosition();
  ASSERT_TRUE(later.has_value());
  EXPECT_DOUBLE_EQ(*later, rest_position);
  auto sw = master_->ReadU16(kNode, 0x6041, 0, SteadyClock::Instance().Now() + 1s);
  ASSERT_TRUE(sw.ok()) << sw.status();
  EXPECT_EQ(*sw & 0x4F, 0x40) << "status word 0x" << std::hex << *sw;
  // The simulator's motion log names the reaction.
  EXPECT_NE(sim_->log().find("heartbeat of node 127 lost"), std::string::npos) << sim_->log();
  EXPECT_NE(sim_->log().find("6007h = 3 quick stop"), std::string::npos) << sim_->log();
  EXPECT_TRUE(sim_->Running());
}

}  // namespace
}  // namespace drivegw::testing
