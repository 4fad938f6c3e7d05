// MoveAbsolute acknowledged through the gateway (gRPC -> core -> LinUDP session -> simulated
// drive -> count echo), against baselines measured in the same run: a bare gRPC unary echo and
// a bare LinUDP round trip to the same kind of simulated drive. Prints p50/p99 and the ratio
// gateway / (gRPC echo + UDP round trip); target ≤ 1.3 (docs/performance.md).
#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <vector>

#include "adapters/linmot/linudp/codec.h"
#include "adapters/transport/udp_socket.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/gateway.h"
#include "sim/linmot/server.h"

namespace {

using Clock = std::chrono::steady_clock;
using drivegw::server::Gateway;

int g_errors = 0;  // failed moves (time-outs), reported with the results

struct Stats {
  double p50_us = 0, p99_us = 0;
};

Stats Summarize(std::vector<double> us) {
  if (us.empty()) return {};
  std::sort(us.begin(), us.end());
  auto at = [&](double q) { return us[static_cast<size_t>(q * static_cast<double>(us.size() - 1))]; };
  return {at(0.50), at(0.99)};
}

// Bare gRPC unary echo: a callback generic service returning the request bytes.
class EchoService final : public grpc::CallbackGenericService {
  grpc::ServerGenericBidiReactor* CreateReactor(grpc::GenericCallbackServerContext*) override {
    class Reactor final : public grpc::ServerGenericBidiReactor {
     public:
      Reactor() { StartRead(&buf_); }
      void OnReadDone(bool ok) override {
        if (!ok) {
          Finish(grpc::Status::OK);
          return;
        }
        StartWrite(&buf_);
      }
      void OnWriteDone(bool) override { Finish(grpc::Status::OK); }
      void OnDone() override { delete this; }

     private:
      grpc::ByteBuffer buf_;
    };
    return new Reactor;
  }
};

std::vector<double> MeasureGrpcEcho(int n) {
  EchoService echo;
  grpc::ServerBuilder b;
  int port = 0;
  b.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  b.RegisterCallbackGenericService(&echo);
  auto server = b.BuildAndStart();
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  grpc::GenericStub stub(channel);
  // Same payload size as a MoveAbsoluteRequest.
  drivegw::v1::MoveAbsoluteRequest req;
  req.set_name("drives/x1");
  req.set_position_mm(40);
  req.set_velocity_mm_s(1000);
  req.set_acceleration_mm_s2(10000);
  const std::string bytes = req.SerializeAsString();
  std::vector<double> us;
  for (int i = 0; i < n + 50; ++i) {
    grpc::Slice slice(bytes);
    grpc::ByteBuffer in(&slice, 1), out;
    grpc::ClientContext ctx;
    std::promise<grpc::Status> done;
    const auto t0 = Clock::now();
    stub.UnaryCall(&ctx, "/bench.Echo/Echo", grpc::StubOptions(), &in, &out,
                   [&](grpc::Status s) { done.set_value(s); });
    grpc::Status s = done.get_future().get();
    const auto t1 = Clock::now();
    if (!s.ok()) {
      std::fprintf(stderr, "echo failed: %s\n", s.error_message().c_str());
      std::exit(1);
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  server->Shutdown();
  return us;
}

// Bare LinUDP round trip: a status poll (linmot-linudp.md §9 telegram 1) to a simulated drive.
std::vector<double> MeasureUdpRoundTrip(drivegw::sim::linmot::LinMotServer& sim, int n) {
  namespace linudp = drivegw::linmot::linudp;
  auto sock = drivegw::transport::UdpSocket::Bind(drivegw::transport::Endpoint{0x7F000001, 0});
  if (!sock.ok()) {
    std::fprintf(stderr, "udp bind: %s\n", std::string(sock.status().message()).c_str());
    std::exit(1);
  }
  linudp::Request req;
  req.response_definition = 0x7F;
  const std::vector<uint8_t> bytes = linudp::EncodeRequest(req);
  std::vector<double> us;
  for (int i = 0; i < n + 50; ++i) {
    const auto t0 = Clock::now();
    if (!sock->SendTo(sim.endpoint(), bytes).ok()) std::exit(1);
    auto got = sock->Receive(std::chrono::milliseconds(500));
    const auto t1 = Clock::now();
    if (!got.ok() || !got->has_value()) {
      std::fprintf(stderr, "udp round trip: no reply\n");
      std::exit(1);
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

std::vector<double> MeasureMoveAck(Gateway& gw, int n) {
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw.grpc_port()), grpc::InsecureChannelCredentials());
  auto stub = drivegw::v1::DriveService::NewStub(channel);
  {
    grpc::ClientContext ctx;
    drivegw::v1::EnableRequest en;
    en.set_name("drives/x1");
    drivegw::v1::CommandHandle h;
    grpc::Status s = stub->Enable(&ctx, en, &h);
    if (!s.ok() || h.state() != drivegw::v1::DONE) {
      std::fprintf(stderr, "enable failed: %s %s\n", s.error_message().c_str(), h.ShortDebugString().c_str());
      std::exit(1);
    }
  }
  std::vector<double> us;
  for (int i = 0; i < n + 50; ++i) {
    drivegw::v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(i % 2 == 0 ? 40 : 60);
    req.set_velocity_mm_s(1000);
    req.set_acceleration_mm_s2(10000);
    drivegw::v1::CommandHandle h;
    grpc::ClientContext ctx;
    const auto t0 = Clock::now();
    grpc::Status s = stub->MoveAbsolute(&ctx, req, &h);
    const auto t1 = Clock::now();
    if (!s.ok()) {
      // A loaded machine can miss the 100 ms acceptance time-out (D-11); count, do not die.
      ++g_errors;
      std::fprintf(stderr, "move %d failed: %s\n", i, s.error_message().c_str());
      continue;
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

// The same call without gRPC: the core's MoveAbsolute straight into the drive and the session,
// to split the gateway's own cost from the gRPC hop.
std::vector<double> MeasureCoreMoveAck(Gateway& gw, int n) {
  std::vector<double> us;
  drivegw::server::CallContext cc;
  for (int i = 0; i < n + 50; ++i) {
    drivegw::v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(i % 2 == 0 ? 40 : 60);
    req.set_velocity_mm_s(1000);
    req.set_acceleration_mm_s2(10000);
    const auto t0 = Clock::now();
    auto h = gw.core().MoveAbsolute(req, cc);
    const auto t1 = Clock::now();
    if (!h.ok()) {
      ++g_errors;
      std::fprintf(stderr, "core move %d failed: %s\n", i, std::string(h.status().message()).c_str());
      continue;
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 2000;
  char tmpl[] = "/tmp/drivegw-bench-XXXXXX";
  if (::mkdtemp(tmpl) == nullptr) return 1;
  drivegw::server::GatewayOptions o;
  o.config.listen.grpc = "127.0.0.1:0";
  o.config.listen.http = "127.0.0.1:0";
  o.config.data_dir = tmpl;
  o.demo_first_port = 0;
  o.demo_master_port = 0;
  o.demo_can_port = static_cast<uint16_t>(20000 + ::getpid() % 20000);  // a bus of its own
  auto gw = Gateway::Start(std::move(o));
  if (!gw.ok()) {
    std::fprintf(stderr, "gateway: %s\n", std::string(gw.status().message()).c_str());
    return 1;
  }
  // Interleave the three measurements in rounds so machine noise hits all of them alike.
  std::vector<double> echo, udp, move, core;
  const int rounds = 4;
  for (int r = 0; r < rounds; ++r) {
    auto e = MeasureGrpcEcho(n / rounds);
    auto u = MeasureUdpRoundTrip(*(*gw)->demo_simulator("x2"), n / rounds);
    auto m = MeasureMoveAck(**gw, n / rounds);
    auto c = MeasureCoreMoveAck(**gw, n / rounds);
    core.insert(core.end(), c.begin(), c.end());
    echo.insert(echo.end(), e.begin(), e.end());
    udp.insert(udp.end(), u.begin(), u.end());
    move.insert(move.end(), m.begin(), m.end());
  }
  const Stats se = Summarize(echo), su = Summarize(udp), sm = Summarize(move), sc = Summarize(core);
  std::printf("%-38s %10s %10s\n", "measurement (n per row)", "p50 us", "p99 us");
  std::printf("%-38s %10.1f %10.1f\n", "baseline: bare gRPC unary echo", se.p50_us, se.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "baseline: bare LinUDP round trip", su.p50_us, su.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "baseline sum (echo + round trip)", se.p50_us + su.p50_us, se.p99_us + su.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "MoveAbsolute acknowledged (gateway)", sm.p50_us, sm.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "  of which without gRPC (core direct)", sc.p50_us, sc.p99_us);
  std::printf("ratio p50 %.2f  p99 %.2f  (target <= 1.3), n=%zu\n", sm.p50_us / (se.p50_us + su.p50_us),
              sm.p99_us / (se.p99_us + su.p99_us), move.size());
  std::printf("failed moves: %d of %zu\n", g_errors, move.size() + core.size() + static_cast<size_t>(g_errors));
  (*gw)->Stop();
  std::filesystem::remove_all(tmpl);
  // More than 5 % failures means the measurement is meaningless.
  return g_errors * 20 > static_cast<int>(move.size() + core.size()) ? 1 : 0;
}
