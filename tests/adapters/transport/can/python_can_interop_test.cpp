// Interop with python-can's udp_multicast interface (Debian python3-can, run by /usr/bin/python3):
// frames both ways, byte-exact packing, error frames, and python-can reading our candump trace.
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "adapters/transport/can_channel.h"
#include "adapters/transport/udp_multicast_channel.h"
#include "gmock/gmock.h"
#include "gtest/gtest.h"

namespace drivegw::transport {
namespace {

using std::chrono::milliseconds;
using std::chrono::seconds;
using ::testing::ElementsAre;

constexpr char kPython[] = "/usr/bin/python3";  // the pyenv python3 on PATH lacks apt modules
constexpr char kGroup[] = "239.74.163.88";

bool PythonCanInstalled() {
  return std::system(absl::StrCat(kPython, " -c 'import can, msgpack' >/dev/null 2>&1").c_str()) ==
         0;
}

#define REQUIRE_PYTHON_CAN()                                                          \
  do {                                                                                \
    if (!PythonCanInstalled()) {                                                      \
      GTEST_SKIP() << "python-can is missing: apt-get install python3-can (it is in " \
                      "scripts/install-deps.sh)";                                     \
    }                                                                                 \
  } while (false)

uint16_t UniquePort() {
  static std::atomic<int> next{0};
  return static_cast<uint16_t>(20000 + (::getpid() * 16 + 8 + next++) % 40000);
}

std::string TempDir() { return std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp"; }

// Runs a python script (written to a temp file) with arguments; a pipe on its stdout.
class PythonProcess {
 public:
  PythonProcess(const std::string& script, const std::string& args) {
    path_ = absl::StrCat(TempDir(), "/dgw_pycan_", ::getpid(), "_", counter_++, ".py");
    std::ofstream(path_) << script;
    // `timeout` bounds a hung script; 2>&1 so a traceback shows up in the test output.
    pipe_ =
        ::popen(absl::StrCat("timeout 30 ", kPython, " ", path_, " ", args, " 2>&1").c_str(), "r");
  }
  ~PythonProcess() {
    if (pipe_) ::pclose(pipe_);
    ::unlink(path_.c_str());
  }
  // One line without the newline; nullopt at end of output.
  std::optional<std::string> ReadLine() {
    std::array<char, 4096> buf;
    if (!pipe_ || !std::fgets(buf.data(), buf.size(), pipe_)) return std::nullopt;
    std::string line(buf.data());
    if (!line.empty() && line.back() == '\n') line.pop_back();
    return line;
  }
  std::vector<std::string> ReadAll() {
    std::vector<std::string> lines;
    while (auto l = ReadLine()) lines.push_back(*l);
    return lines;
  }
  // Exit status (after all output was read).
  int Wait() {
    const int status = ::pclose(pipe_);
    pipe_ = nullptr;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  static inline std::atomic<int> counter_{0};
  std::string path_;
  FILE* pipe_ = nullptr;
};

std::unique_ptr<UdpMulticastChannel> OpenBus(uint16_t port) {
  auto ch = UdpMulticastChannel::Open({.group = kGroup, .port = port});
  EXPECT_TRUE(ch.ok()) << ch.status();
  return ch.ok() ? *std::move(ch) : nullptr;
}

constexpr char kPythonSender[] = R"py(
import sys, can
group, port = sys.argv[1], int(sys.argv[2])
bus = can.Bus(interface="udp_multicast", channel=group, port=port)
msgs = [
    can.Message(arbitration_id=0x42E, is_extended_id=False, data=[0x00, 0x4B, 0x03, 0x01, 0x03]),
    can.Message(arbitration_id=0x1ABCDEF0, is_extended_id=True, data=bytes(range(1, 9))),
    can.Message(arbitration_id=0x7FF, is_extended_id=False, is_remote_frame=True, dlc=3),
    can.Message(arbitration_id=0x000, is_extended_id=False, data=b""),
    can.Message(is_error_frame=True),
    can.Message(arbitration_id=0x123, is_extended_id=True, data=[0xFF]),
]
for m in msgs:
    bus.send(m)
print("sent", len(msgs), flush=True)
bus.shutdown()
)py";

TEST(PythonCanInterop, PythonSends_WeReceive) {
  REQUIRE_PYTHON_CAN();
  const uint16_t port = UniquePort();
  auto bus = OpenBus(port);
  ASSERT_TRUE(bus);
  PythonProcess py(kPythonSender, absl::StrCat(kGroup, " ", port));
  std::vector<std::string> got;
  const auto deadline = std::chrono::steady_clock::now() + seconds(20);
  while (got.size() < 5 && std::chrono::steady_clock::now() < deadline) {
    auto f = bus->Receive(milliseconds(200));
    ASSERT_TRUE(f.ok()) << f.status();
    if (f->has_value()) got.push_back(FormatCanFrame(**f));
  }
  EXPECT_THAT(py.ReadAll(), ElementsAre("sent 6"));
  EXPECT_EQ(py.Wait(), 0);
  EXPECT_THAT(got, ElementsAre("42E#004B030103", "1ABCDEF0#0102030405060708", "7FF#R3", "000#",
                               "00000123#FF"));
  EXPECT_EQ(bus->counters().error_frames, 1u);
  EXPECT_EQ(bus->counters().dropped_malformed, 0u);
}

constexpr char kPythonReceiver[] = R"py(
import sys, can
group, port, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
bus = can.Bus(interface="udp_multicast", channel=group, port=port)
print("ready", flush=True)
n = 0
while n < count:
    m = bus.recv(timeout=10)  # check=True inside: our packing must satisfy can.Message._check
    if m is None:
        print("timeout", flush=True)
        break
    print("%x %d %d %d %s" % (m.arbitration_id, m.is_extended_id, m.is_remote_frame, m.dlc,
                              m.data.hex() or "-"), flush=True)
    n += 1
bus.shutdown()
)py";

TEST(PythonCanInterop, WeSend_PythonReceives) {
  REQUIRE_PYTHON_CAN();
  const uint16_t port = UniquePort();
  auto bus = OpenBus(port);
  ASSERT_TRUE(bus);
  PythonProcess py(kPythonReceiver, absl::StrCat(kGroup, " ", port, " 5"));
  ASSERT_EQ(py.ReadLine(), "ready");
  const std::vector<uint8_t> eight{1, 2, 3, 4, 5, 6, 7, 8};
  const std::vector<uint8_t> five{0x00, 0x4B, 0x03, 0x01, 0x03};
  ASSERT_TRUE(bus->Send(MakeCanFrame(0x42E, five)).ok());
  ASSERT_TRUE(bus->Send(MakeCanFrame(0x1ABCDEF0, eight, true)).ok());
  ASSERT_TRUE(bus->Send(MakeCanRtrFrame(0x7FF, 3)).ok());
  ASSERT_TRUE(bus->Send(MakeCanFrame(0x0, {})).ok());
  ASSERT_TRUE(bus->Send(MakeCanRtrFrame(0x10, 0, true)).ok());
  EXPECT_THAT(py.ReadAll(), ElementsAre("42e 0 0 5 004b030103", "1abcdef0 1 0 8 0102030405060708",
                                        "7ff 0 1 3 -", "0 0 0 0 -", "10 1 1 0 -"));
  EXPECT_EQ(py.Wait(), 0);
}

constexpr char kPythonPack[] = R"py(
import can
from can.interfaces.udp_multicast.utils import pack_message
for m in [
    can.Message(timestamp=1700000000.5, arbitration_id=0x42E, is_extended_id=False,
                data=[0x00, 0x4B, 0x03, 0x01, 0x03]),
    can.Message(timestamp=0.0, arbitration_id=0x1FFFFFFF, is_extended_id=True, data=bytes(8)),
    can.Message(timestamp=12.25, arbitration_id=0x7FF, is_extended_id=False,
                is_remote_frame=True, dlc=8),
]:
    print(pack_message(m).hex())
)py";

std::string Hex(const std::vector<uint8_t>& bytes) {
  std::string out;
  char b[3];
  for (uint8_t x : bytes) {
    std::snprintf(b, sizeof(b), "%02x", x);
    out += b;
  }
  return out;
}

TEST(PythonCanInterop, Packing_ByteExactWithMsgpackPython) {
  REQUIRE_PYTHON_CAN();
  PythonProcess py(kPythonPack, "");
  const std::vector<uint8_t> five{0x00, 0x4B, 0x03, 0x01, 0x03};
  const std::vector<uint8_t> zeros(8, 0);
  EXPECT_THAT(py.ReadAll(),
              ElementsAre(Hex(EncodePythonCanMessage(MakeCanFrame(0x42E, five), 1700000000.5)),
                          Hex(EncodePythonCanMessage(MakeCanFrame(0x1FFFFFFF, zeros, true), 0.0)),
                          Hex(EncodePythonCanMessage(MakeCanRtrFrame(0x7FF, 8), 12.25))));
  EXPECT_EQ(py.Wait(), 0);
}

constexpr char kPythonLogReader[] = R"py(
import sys, can
from can.io.canutils import CanutilsLogReader
for m in CanutilsLogReader(sys.argv[1]):
    print("%s %x %d %d %d %d %s" % (m.channel, m.arbitration_id, m.is_extended_id,
                                    m.is_remote_frame, m.is_rx, m.dlc, m.data.hex() or "-"))
)py";

TEST(PythonCanInterop, PythonReadsOurCandumpTrace) {
  REQUIRE_PYTHON_CAN();
  const std::string path = absl::StrCat(TempDir(), "/dgw_pycan_trace.", ::getpid(), ".log");
  ::unlink(path.c_str());
  const uint16_t port = UniquePort();
  CanBusConfig config;
  config.group = kGroup;
  config.port = port;
  config.trace_file = path;
  auto traced = OpenCanChannel(config);
  ASSERT_TRUE(traced.ok()) << traced.status();
  auto peer = OpenBus(port);
  ASSERT_TRUE(peer);
  const std::vector<uint8_t> two{0xAB, 0xCD};
  ASSERT_TRUE((*traced)->Send(MakeCanFrame(0x42E, two)).ok());
  ASSERT_TRUE(peer->Send(MakeCanRtrFrame(0x1234567, 4, true)).ok());
  auto f = (*traced)->Receive(seconds(5));
  ASSERT_TRUE(f.ok() && f->has_value());
  PythonProcess py(kPythonLogReader, path);
  const std::string name = (*traced)->name();
  EXPECT_THAT(py.ReadAll(), ElementsAre(name + " 42e 0 0 0 2 abcd", name + " 1234567 1 1 1 4 -"));
  EXPECT_EQ(py.Wait(), 0);
  ::unlink(path.c_str());
}

}  // namespace
}  // namespace drivegw::transport
