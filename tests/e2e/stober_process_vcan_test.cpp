// Issue 5 "SocketCAN VM test" in the product's shape: `drivegw-sim stober --can ... --node 3` and
// the `drivegw` gateway (config family stober, node_id 3) run as separate processes, and the
// scenario is driven over the gateway's REST API only: list drives, the drive leaves OFFLINE,
// Enable, MoveAbsolute, poll the command until DONE, read the position, a native CanOpenSdo read
// of 6041h, Disable. Once with event-driven RPDOs (the default) and once with
// `canopen.rpdo_transmission_type: 1` (synchronous, decision 1119): the axis then moves only if the
// gateway's SYNC applies each RPDO, and the node's 1400h sub 2 shows the type the gateway wrote.
//
// Bus: SocketCAN `DGW_CAN_IFACE` (vcan0 in tests/socketcan-vm, where run.sh copies drivegw and
// drivegw-sim next to this binary), else a user-space UDP multicast bus of this run's own, so
// ctest on a host without CAN runs the same scenario. Binaries: $DGW_DRIVEGW / $DGW_DRIVEGW_SIM,
// else next to this test, else the build tree's. Every wait has a deadline; none asserts timing.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/e2e/child_process.h"
#include "tests/e2e/http_client.h"

extern char** environ;

namespace drivegw::testing {
namespace {

using namespace std::chrono_literals;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// Emulated (TCG) VM: process start-up and every exchange are many times slower than on a host.
constexpr auto kDeadline = 45s;
constexpr int kNode = 3;

std::string SelfDir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : exe.parent_path().string();
}

std::string FindBinary(const char* env, const char* name, const char* built) {
  if (const char* e = std::getenv(env); e != nullptr && *e != '\0') return e;
  const std::string beside = SelfDir() + "/" + name;
  if (::access(beside.c_str(), X_OK) == 0) return beside;
  return built;
}

using test_support::ChildProcess;
using test_support::Tail;
std::string ReadFile(const std::string& path) { return test_support::ReadWholeFile(path); }

// Polls `pred` every 20 ms until it holds, `timeout` passes or `alive` (when given) turns false.
bool Eventually(const std::function<bool()>& pred, std::chrono::milliseconds timeout,
                const std::function<bool()>& alive = nullptr) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (pred()) return true;
    if (alive && !alive()) return pred();
    std::this_thread::sleep_for(20ms);
  }
  return pred();
}

std::vector<uint8_t> Base64(const std::string& in) {
  static const std::string kAlphabet =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::vector<uint8_t> out;
  uint32_t acc = 0;
  int bits = 0;
  for (char c : in) {
    const size_t v = kAlphabet.find(c);
    if (v == std::string::npos) continue;  // '=' padding
    acc = acc << 6 | static_cast<uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<uint8_t>(acc >> bits));
    }
  }
  return out;
}

struct Bus {
  std::string sim_spec;     // drivegw-sim --can
  std::string config_yaml;  // the drive's can: mapping
  std::string name;
};

Bus PickBus() {
  if (const char* iface = std::getenv("DGW_CAN_IFACE"); iface != nullptr && *iface != '\0') {
    return {std::string("socketcan:") + iface,
            std::string("{socketcan: {interface: ") + iface + "}}",
            std::string("socketcan ") + iface};
  }
  std::random_device rd;
  const int port = 20000 + static_cast<int>(rd() % 40000);
  const std::string group = "239.74.163." + std::to_string(150 + rd() % 100);
  return {"udp:" + group + ":" + std::to_string(port),
          "{udp: {group: " + group + ", port: " + std::to_string(port) + "}}",
          "user-space udp:" + group + ":" + std::to_string(port)};
}

class StoberProcessTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override {
    char tmpl[] = "/tmp/drivegw-stober-proc-XXXXXX";
    ASSERT_NE(::mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    bus_ = PickBus();
    const std::string sim = FindBinary("DGW_DRIVEGW_SIM", "drivegw-sim", DGW_SIM_BIN);
    const std::string gateway = FindBinary("DGW_DRIVEGW", "drivegw", DGW_GATEWAY_BIN);
    std::cout << "bus " << bus_.name << "; " << sim << "; " << gateway << std::endl;

    sim_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{sim, "stober", "--can", bus_.sim_spec, "--node",
                                 std::to_string(kNode)},
        dir_ + "/sim.log");
    ASSERT_TRUE(sim_->started()) << sim << ": posix_spawn error " << sim_->spawn_error();
    ASSERT_TRUE(Eventually([&] { return sim_->log().find("stober node") != std::string::npos; },
                           kDeadline, [&] { return sim_->Running(); }))
        << "drivegw-sim did not come up: " << sim_->Describe();

    const std::string config = dir_ + "/drivegw.yaml";
    std::ofstream(config) << "listen: {grpc: '127.0.0.1:0', http: '127.0.0.1:0'}\n"
                          << "data_dir: " << dir_ << "/data\n"
                          << "drives:\n"
                          << "  - name: s1\n"
                          << "    family: stober\n"
                          << "    can: " << bus_.config_yaml << "\n"
                          << "    node_id: " << kNode
                          << "\n"
                          // Generous link supervision and SDO time-outs for the emulated VM.
                          << "    canopen: {heartbeat_ms: 100, heartbeat_timeout_ms: 1500, "
                          << "sync_period_ms: 10, sdo_timeout_ms: 3000, rpdo_transmission_type: "
                          << GetParam() << "}\n"
                          << "    timeouts: {request_ms: 10000, accept_ms: 2000}\n"
                          << "    axis: {min_mm: -10000, max_mm: 10000, max_velocity_mm_s: 1000, "
                          << "max_acceleration_mm_s2: 10000}\n";
    gateway_ = std::make_unique<ChildProcess>(std::vector<std::string>{gateway, "--config", config},
                                              dir_ + "/drivegw.log");
    ASSERT_TRUE(gateway_->started())
        << gateway << ": posix_spawn error " << gateway_->spawn_error();
    // "drivegw: gRPC on :P, HTTP on :Q — Ctrl-C stops" (server/main.cpp).
    ASSERT_TRUE(Eventually(
        [&] {
          const std::string log = gateway_->log();
          const size_t at = log.find("HTTP on :");
          if (at == std::string::npos) return false;
          http_port_ = std::atoi(log.c_str() + at + 9);
          return http_port_ > 0;
        },
        kDeadline, [&] { return gateway_->Running(); }))
        << "drivegw did not start: " << gateway_->Describe();
  }

  void TearDown() override {
    gateway_.reset();
    sim_.reset();
    if (HasFailure()) {
      std::cout << "--- drivegw-sim output:\n"
                << Tail(ReadFile(dir_ + "/sim.log")) << "\n--- drivegw output:\n"
                << Tail(ReadFile(dir_ + "/drivegw.log"), 6000) << std::endl;
    }
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

  // Both processes still run (a wait ends early, with their output, when one died).
  std::function<bool()> Alive() {
    return [this] { return gateway_->Running() && sim_->Running(); };
  }

  // One request; the body parsed (null when it is not JSON).
  std::pair<int, Json> Call(const std::string& method, const std::string& target,
                            const std::string& body = "") {
    const HttpResponse r = HttpRequest(http_port_, method, target, body);
    last_body_ = r.body;
    return {r.status, Json::parse(r.body, nullptr, false)};
  }
  Json Drive() {
    auto [status, j] = Call("GET", "/v1/drives/s1");
    return status == 200 ? j : Json();
  }
  std::string State() {
    const Json d = Drive();
    return d.is_object() ? d["status"].value("state", "") : "";
  }
  // The object's bytes from a CanOpenSdo upload through the gateway.
  std::vector<uint8_t> SdoRead(int index, int sub) {
    auto [status, j] = Call("POST", "/v1/drives/s1:sendNativeCommand",
                            Json{{"canopen_sdo", {{"index", index}, {"sub_index", sub}}}}.dump());
    EXPECT_EQ(status, 200) << last_body_;
    return j.is_object() ? Base64(j.value("reply", "")) : std::vector<uint8_t>{};
  }

  std::string dir_;
  Bus bus_;
  std::unique_ptr<ChildProcess> sim_;
  std::unique_ptr<ChildProcess> gateway_;
  int http_port_ = 0;
  std::string last_body_;
};

TEST_P(StoberProcessTest, ListEnableMoveAbsoluteSdoDisable_OverRest) {
  // 1. The configured drive is listed, with its family.
  auto [list_status, list] = Call("GET", "/v1/drives");
  ASSERT_EQ(list_status, 200) << last_body_;
  ASSERT_EQ(list["drives"].size(), 1u) << last_body_;
  EXPECT_EQ(list["drives"][0]["name"], "drives/s1");
  EXPECT_EQ(list["drives"][0]["family"], "stober");

  // 2. Online: the gateway configured node 3 and sees its heartbeat.
  ASSERT_TRUE(Eventually(
      [&] {
        const std::string s = State();
        return !s.empty() && s != "OFFLINE" && s != "DRIVE_STATE_UNSPECIFIED";
      },
      kDeadline, Alive()))
      << "drive stayed " << State() << ": " << Drive().dump();

  // The gateway wrote the configured RPDO transmission type (1400h sub 2, CiA 301 §7.5.2.35).
  EXPECT_EQ(SdoRead(0x1400, 2), (std::vector<uint8_t>{static_cast<uint8_t>(GetParam())}));

  // 3. Enable: CiA 402 up to Operation enabled.
  auto [en_status, en] = Call("POST", "/v1/drives/s1:enable", "{}");
  ASSERT_EQ(en_status, 200) << last_body_;
  EXPECT_EQ(en.value("state", ""), "DONE") << last_body_;

  // 4. MoveAbsolute to 25 mm (1 u = 1 mm, decision 409), then poll the handle until DONE.
  auto [mv_status, mv] =
      Call("POST", "/v1/drives/s1:moveAbsolute",
           R"({"position_mm": 25, "velocity_mm_s": 100, "acceleration_mm_s2": 1000})");
  ASSERT_EQ(mv_status, 200) << last_body_;
  EXPECT_EQ(mv.value("kind", ""), "MoveAbsolute") << last_body_;
  const std::string handle = mv.value("name", "");
  ASSERT_EQ(handle.rfind("drives/s1/commands/", 0), 0u) << last_body_;
  std::string final_state;
  ASSERT_TRUE(Eventually(
      [&] {
        auto [status, h] = Call("GET", "/v1/" + handle);
        final_state = status == 200 ? h.value("state", "") : "";
        return final_state == "DONE" || final_state == "ERROR" || final_state == "ABORTED";
      },
      kDeadline, Alive()))
      << "MoveAbsolute still " << final_state << ": " << last_body_;
  EXPECT_EQ(final_state, "DONE") << last_body_;

  // 5. The position the node reports (TPDO2, 0.001 u) — it may trail the Done of TPDO1.
  double position = 0;
  EXPECT_TRUE(Eventually(
      [&] {
        position = Drive()["status"].value("position_mm", 0.0);
        return std::abs(position - 25.0) < 0.001;
      },
      kDeadline, Alive()))
      << "position " << position << ": " << Drive().dump();

  // 6. Native CanOpenSdo upload of 6041h: Operation enabled (xxxx xxxx x01x 0111, CiA 402).
  const std::vector<uint8_t> sw = SdoRead(0x6041, 0);
  ASSERT_EQ(sw.size(), 2u) << last_body_;
  EXPECT_EQ((sw[0] | sw[1] << 8) & 0x6F, 0x27)
      << "status word 0x" << std::hex << (sw[0] | sw[1] << 8);

  // 7. Disable: the power stage goes off, the drive leaves ENABLED.
  auto [dis_status, dis] = Call("POST", "/v1/drives/s1:disable", "{}");
  ASSERT_EQ(dis_status, 200) << last_body_;
  EXPECT_EQ(dis.value("state", ""), "DONE") << last_body_;
  EXPECT_TRUE(
      Eventually([&] { return State() != "ENABLED" && !State().empty(); }, kDeadline, Alive()))
      << Drive().dump();
  const std::vector<uint8_t> off = SdoRead(0x6041, 0);
  ASSERT_EQ(off.size(), 2u) << last_body_;
  EXPECT_NE((off[0] | off[1] << 8) & 0x6F, 0x27) << "still Operation enabled";

  EXPECT_TRUE(sim_->Running()) << sim_->Describe();
  EXPECT_TRUE(gateway_->Running()) << gateway_->Describe();
}

INSTANTIATE_TEST_SUITE_P(RpdoTransmission, StoberProcessTest, ::testing::Values(255, 1),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return info.param == 1 ? std::string("Synchronous")
                                                  : std::string("EventDriven");
                         });

}  // namespace
}  // namespace drivegw::testing
