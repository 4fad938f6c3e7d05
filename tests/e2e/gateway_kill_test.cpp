// Safe recovery across a SIGKILL of the gateway process (issue 11, docs/reliability.md "Safe
// recovery", gap 11; decision 1451). The simulated drive lives in this test process; the gateway
// is the `drivegw` binary with a configuration file naming that drive, driven over REST. It moves
// the axis to A, starts a slow move to B and is killed (SIGKILL: no shutdown path runs) mid-move;
// a new `drivegw` on the same data directory starts and enables the drive. The simulator's own
// record must show nothing executed on start-up or on enable, the axis where the drive left it,
// and only a new command moves it. One test per family.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "tests/e2e/child_process.h"
#include "tests/e2e/http_client.h"
#include "tests/e2e/recovery_sims.h"

namespace drivegw {
namespace {

using Json = nlohmann::json;
using namespace std::chrono_literals;
using test_support::ChildProcess;
using test_support::FamilySim;

constexpr auto kDeadline = 45s;  // process start-up on a host at load 6-10

bool Eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout = kDeadline) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(5ms);
  }
  return true;
}

class GatewayKillTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-kill-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override {
    gateway_.reset();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  // Starts `drivegw --config` with the one drive; returns its HTTP port (0 on failure).
  void StartGateway(const FamilySim& f, int generation) {
    const std::string config = dir_ + "/drivegw.yaml";
    std::ofstream(config) << "listen: {grpc: '127.0.0.1:0', http: '127.0.0.1:0'}\n"
                          << "data_dir: " << dir_ << "/data\n"
                          << "drives:\n"
                          << f.yaml;
    const char* env = std::getenv("DGW_DRIVEGW");
    const std::string bin = env != nullptr && *env != '\0' ? env : DGW_GATEWAY_BIN;
    gateway_ = std::make_unique<ChildProcess>(std::vector<std::string>{bin, "--config", config},
                                              absl::StrCat(dir_, "/drivegw-", generation, ".log"));
    ASSERT_TRUE(gateway_->started()) << bin << ": posix_spawn error " << gateway_->spawn_error();
    // "drivegw: gRPC on :P, HTTP on :Q — Ctrl-C stops" (server/main.cpp).
    http_port_ = 0;
    ASSERT_TRUE(Eventually([&] {
      const std::string log = gateway_->log();
      const size_t at = log.find("HTTP on :");
      if (at != std::string::npos) http_port_ = std::atoi(log.c_str() + at + 9);
      return http_port_ > 0 || !gateway_->Running();
    }));
    ASSERT_GT(http_port_, 0) << "drivegw did not start:\n" << gateway_->log();
    drive_path_ = "/v1/drives/" + f.drive.name;
  }

  std::pair<int, Json> Call(const std::string& method, const std::string& target,
                            const std::string& body = "") {
    const testing::HttpResponse r = testing::HttpRequest(http_port_, method, target, body);
    last_body_ = r.body;
    return {r.status, Json::parse(r.body, nullptr, false)};
  }
  Json Status() {
    auto [code, j] = Call("GET", drive_path_);
    return code == 200 && j.is_object() ? j["status"] : Json::object();
  }
  std::string State() { return Status().value("state", ""); }
  // Replies of the drive on its link (status.link, issue 8): a count of exchanges, not a time.
  uint64_t Replies() {
    const Json link = Status().value("link", Json::object());
    const Json r = link.value("replies", Json("0"));
    return r.is_string() ? std::stoull(r.get<std::string>()) : r.get<uint64_t>();
  }
  bool Online() {
    const std::string s = State();
    return !s.empty() && s != "OFFLINE" && s != "DRIVE_STATE_UNSPECIFIED";
  }
  // Runs a command over REST; for motion, waits until the handle is final. Returns its state.
  std::string Command(const std::string& verb, const std::string& body = "{}") {
    auto [code, h] = Call("POST", drive_path_ + ":" + verb, body);
    EXPECT_EQ(code, 200) << verb << ": " << last_body_;
    if (code != 200) return "";
    std::string state = h.value("state", "");
    const std::string name = h.value("name", "");
    Eventually([&] {
      auto [c, g] = Call("GET", "/v1/" + name);
      state = c == 200 ? g.value("state", "") : state;
      return state == "DONE" || state == "ERROR" || state == "ABORTED";
    });
    return state;
  }
  static std::string MoveBody(const MoveAbsolute& m) {
    return Json{{"position_mm", m.position_mm},
                {"velocity_mm_s", m.velocity_mm_s},
                {"acceleration_mm_s2", m.acceleration_mm_s2},
                {"deceleration_mm_s2", m.deceleration_mm_s2}}
        .dump();
  }
  std::string MoveAndWait(const MoveAbsolute& m) { return Command("moveAbsolute", MoveBody(m)); }

  void Run(FamilySim& f) {
    // --- First gateway process: A, then a slow move to B, killed mid-move.
    StartGateway(f, 1);
    ASSERT_TRUE(Eventually([&] { return Online(); })) << Status().dump();
    if (State() == "FAULT") {
      ASSERT_EQ(Command("acknowledgeFault"), "DONE");
    }
    ASSERT_EQ(Command("enable"), "DONE") << last_body_;
    if (f.home_first) {
      ASSERT_EQ(Command("home"), "DONE") << last_body_;
    }
    ASSERT_EQ(MoveAndWait(f.to_a), "DONE") << last_body_;
    ASSERT_NEAR(f.sim.position_mm(), f.to_a.position_mm, f.standstill_tolerance_mm);
    auto [code, h] = Call("POST", drive_path_ + ":moveAbsolute", MoveBody(f.to_b));
    ASSERT_EQ(code, 200) << last_body_;
    const double span = std::abs(f.to_b.position_mm - f.to_a.position_mm);
    ASSERT_TRUE(Eventually([&] {
      return f.sim.moving() && std::abs(f.sim.position_mm() - f.to_a.position_mm) > 0.1 * span;
    })) << "move to B never got under way";
    gateway_->Kill();
    const double killed_at = f.sim.position_mm();
    EXPECT_LT(std::abs(killed_at - f.to_b.position_mm), span) << "the kill did not land mid-move";
    ASSERT_TRUE(Eventually([&] { return !f.sim.moving(); })) << "simulated axis never stood";
    const double rest = f.sim.position_mm();
    std::cout << "kill: A=" << f.to_a.position_mm << " B=" << f.to_b.position_mm << " killed at "
              << killed_at << " drive came to rest at " << rest << "\n";
    f.sim.mark();
    const uint64_t before = f.sim.motion_commands();

    // --- Second process on the same data directory: start-up and enable send nothing.
    StartGateway(f, 2);
    ASSERT_TRUE(Eventually([&] { return Online(); })) << Status().dump();
    uint64_t from = Replies();
    EXPECT_TRUE(Eventually([&] { return Replies() >= from + 20; })) << Status().dump();
    EXPECT_EQ(f.sim.motion_commands(), before) << "motion command sent on start-up";
    EXPECT_NEAR(f.sim.position_mm(), rest, f.standstill_tolerance_mm) << "moved on start-up";
    if (State() == "FAULT") {
      ASSERT_EQ(Command("acknowledgeFault"), "DONE") << last_body_;
    }
    ASSERT_EQ(Command("enable"), "DONE") << last_body_;
    from = Replies();
    EXPECT_TRUE(Eventually([&] { return Replies() >= from + 40; })) << Status().dump();
    EXPECT_EQ(f.sim.motion_commands(), before) << "motion command sent on enable";
    EXPECT_FALSE(f.sim.moving());
    EXPECT_NEAR(f.sim.position_mm(), rest, f.standstill_tolerance_mm) << "moved on enable";

    // --- Only a new command moves it.
    EXPECT_EQ(MoveAndWait(f.to_c), "DONE") << last_body_;
    EXPECT_GT(f.sim.motion_commands(), before);
    EXPECT_NEAR(f.sim.position_mm(), f.to_c.position_mm, f.standstill_tolerance_mm);
    if (HasFailure()) std::cout << "--- drivegw output:\n" << gateway_->log() << std::endl;
  }

  std::string dir_;
  std::unique_ptr<ChildProcess> gateway_;
  int http_port_ = 0;
  std::string drive_path_;
  std::string last_body_;
};

TEST_F(GatewayKillTest, LinUdp_SigkillMidMove_NothingResentAxisStill) {
  auto f = test_support::StartLinUdpSim("k1");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayKillTest, DeviceNet_SigkillMidMove_NothingResentAxisStill) {
  auto f = test_support::StartDeviceNetSim("k2");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayKillTest, Trinamic_SigkillMidMove_NothingResentAxisStill) {
  auto f = test_support::StartTrinamicSim("k3", dir_);
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

TEST_F(GatewayKillTest, Stober_SigkillMidMove_NothingResentAxisStill) {
  auto f = test_support::StartStoberSim("k4");
  ASSERT_TRUE(f.ok()) << f.status();
  Run(*f);
}

}  // namespace
}  // namespace drivegw
