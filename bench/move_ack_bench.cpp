// MoveAbsolute acknowledged through the gateway (gRPC -> core -> LinUDP session -> simulated
// drive -> count echo), against baselines measured in the same run: a bare gRPC unary echo and
// a bare LinUDP round trip to the same kind of simulated drive. Prints p50/p99 and the ratio
// gateway / (gRPC echo + UDP round trip); target ≤ 1.3 (issue 10 P1, docs/performance.md).
// Also splits the gateway's time: at the command's creation, the core without gRPC (blocking and,
// decision 1301, asynchronous), and the core without its audit append, so that the table shows
// where the microseconds beyond the baselines go.
#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <future>
#include <string>
#include <vector>

#include "adapters/linmot/linudp/codec.h"
#include "adapters/transport/udp_socket.h"
#include "bench/report.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/gateway.h"
#include "server/grpc/worker_pool.h"
#include "sim/linmot/server.h"

namespace {

using Clock = std::chrono::steady_clock;
using drivegw::server::Gateway;

int g_errors = 0;  // failed moves (time-outs), reported with the results
// The gateway row split at the handle's create_time (the drive's StartCommand; both clocks are
// this process's system clock): call sent -> command created, command created -> reply received.
std::vector<double> g_to_created, g_from_created;

struct Stats {
  double p50_us = 0, p99_us = 0;
};

Stats Summarize(std::vector<double> us) {
  if (us.empty()) return {};
  std::sort(us.begin(), us.end());
  auto at = [&](double q) {
    return us[static_cast<size_t>(q * static_cast<double>(us.size() - 1))];
  };
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
  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
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
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw.grpc_port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = drivegw::v1::DriveService::NewStub(channel);
  {
    grpc::ClientContext ctx;
    drivegw::v1::EnableRequest en;
    en.set_name("drives/x1");
    drivegw::v1::CommandHandle h;
    grpc::Status s = stub->Enable(&ctx, en, &h);
    if (!s.ok() || h.state() != drivegw::v1::DONE) {
      std::fprintf(stderr, "enable failed: %s %s\n", s.error_message().c_str(),
                   h.ShortDebugString().c_str());
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
    const auto w0 = std::chrono::system_clock::now();
    const auto t0 = Clock::now();
    grpc::Status s = stub->MoveAbsolute(&ctx, req, &h);
    const auto t1 = Clock::now();
    const auto w1 = std::chrono::system_clock::now();
    if (!s.ok()) {
      // A loaded machine can miss the 100 ms acceptance time-out (D-11); count, do not die.
      ++g_errors;
      std::fprintf(stderr, "move %d failed: %s\n", i, s.error_message().c_str());
      continue;
    }
    if (i < 50) continue;
    us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
    const auto created = std::chrono::system_clock::time_point(
        std::chrono::seconds(h.create_time().seconds()) +
        std::chrono::duration_cast<std::chrono::system_clock::duration>(
            std::chrono::nanoseconds(h.create_time().nanos())));
    g_to_created.push_back(std::chrono::duration<double, std::micro>(created - w0).count());
    g_from_created.push_back(std::chrono::duration<double, std::micro>(w1 - created).count());
  }
  return us;
}

// Times n unary calls (after 50 discarded) on a fresh DriveService channel to the gateway; `call`
// makes one call with the given context and must return `want`, or the bench stops.
template <typename Call>
std::vector<double> TimeGatewayCalls(Gateway& gw, int n, grpc::StatusCode want, const char* what,
                                     Call call) {
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw.grpc_port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = drivegw::v1::DriveService::NewStub(channel);
  std::vector<double> us;
  for (int i = 0; i < n + 50; ++i) {
    grpc::ClientContext ctx;
    const auto t0 = Clock::now();
    const grpc::Status s = call(*stub, ctx);
    const auto t1 = Clock::now();
    if (s.error_code() != want) {
      std::fprintf(stderr, "%s: want code %d, got %d %s\n", what, want, s.error_code(),
                   s.error_message().c_str());
      std::exit(1);
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

// A cheap unary call on the gateway's own gRPC server, run inline on gRPC's thread: GetCommand
// of the last move's handle. Its excess over the bare echo is the server's per-call overhead
// (interceptor, authorisation, the larger service).
std::vector<double> MeasureGetCommand(Gateway& gw, int n) {
  drivegw::v1::MoveAbsoluteRequest move;
  move.set_name("drives/x1");
  move.set_position_mm(50);
  move.set_velocity_mm_s(1000);
  move.set_acceleration_mm_s2(10000);
  drivegw::v1::CommandHandle handle;
  {
    // One move for a handle to read; a loaded machine can miss its acceptance time-out (D-11),
    // which counts as a failed move like in MeasureMoveAck, never as a dead bench.
    auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw.grpc_port()),
                                       grpc::InsecureChannelCredentials());
    auto stub = drivegw::v1::DriveService::NewStub(channel);
    grpc::ClientContext ctx;
    if (grpc::Status s = stub->MoveAbsolute(&ctx, move, &handle); !s.ok()) {
      ++g_errors;
      std::fprintf(stderr, "move for GetCommand failed: %s\n", s.error_message().c_str());
      return {};
    }
  }
  drivegw::v1::GetCommandRequest req;
  req.set_name(handle.name());
  drivegw::v1::CommandHandle h;
  return TimeGatewayCalls(gw, n, grpc::StatusCode::OK, "GetCommand",
                          [&](drivegw::v1::DriveService::Stub& stub, grpc::ClientContext& ctx) {
                            return stub.GetCommand(&ctx, req, &h);
                          });
}

// A call that takes the worker-pool path (Offload) but does no work there: ReadParameter of a
// drive that is not configured (NotFound at once, no drive access, no audit). Its excess over
// GetCommand is the hand-off to the pool and the reply finished from a pool thread.
std::vector<double> MeasureOffloadedNoop(Gateway& gw, int n) {
  drivegw::v1::ReadParameterRequest req;
  req.set_name("drives/not-configured");
  req.set_parameter_id(0x1450);
  drivegw::v1::Parameter p;
  return TimeGatewayCalls(gw, n, grpc::StatusCode::NOT_FOUND, "ReadParameter",
                          [&](drivegw::v1::DriveService::Stub& stub, grpc::ClientContext& ctx) {
                            return stub.ReadParameter(&ctx, req, &p);
                          });
}

// The same call without gRPC: the core's MoveAbsolute straight into the drive and the session,
// to split the gateway's own cost from the gRPC hop. `core` is the gateway's (with its audit
// log) or one over the same drives without audit (audit = null), to split the audit append off.
std::vector<double> MeasureCoreMoveAck(drivegw::server::DriveServiceCore& core, int n) {
  std::vector<double> us;
  drivegw::server::CallContext cc;
  for (int i = 0; i < n + 50; ++i) {
    drivegw::v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(i % 2 == 0 ? 40 : 60);
    req.set_velocity_mm_s(1000);
    req.set_acceleration_mm_s2(10000);
    const auto t0 = Clock::now();
    auto h = core.MoveAbsolute(req, cc);
    const auto t1 = Clock::now();
    if (!h.ok()) {
      ++g_errors;
      std::fprintf(stderr, "core move %d failed: %s\n", i,
                   std::string(h.status().message()).c_str());
      continue;
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

// The asynchronous core path the gRPC MoveAbsolute now takes (decision 1301), without gRPC and
// (called with the unaudited core) without the audit append: MoveAbsoluteAsync from the bench
// thread (which sends the telegram when the line is free), the reply evaluated on the session's
// I/O thread, the completion on a pool thread. Its excess over "core direct without audit
// append" is the price of the pool hop against the blocked caller's condition variable.
std::vector<double> MeasureCoreAsyncMoveAck(drivegw::server::DriveServiceCore& core,
                                            drivegw::server::WorkerPool& pool, int n) {
  std::vector<double> us;
  drivegw::server::CallContext cc;
  for (int i = 0; i < n + 50; ++i) {
    drivegw::v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(i % 2 == 0 ? 40 : 60);
    req.set_velocity_mm_s(1000);
    req.set_acceleration_mm_s2(10000);
    std::promise<absl::Status> done;
    const auto t0 = Clock::now();
    core.MoveAbsoluteAsync(req, cc, pool, [&](absl::StatusOr<drivegw::v1::CommandHandle> h) {
      done.set_value(h.status());
    });
    const absl::Status s = done.get_future().get();
    const auto t1 = Clock::now();
    if (!s.ok()) {
      ++g_errors;
      std::fprintf(stderr, "core async move %d failed: %s\n", i, std::string(s.message()).c_str());
      continue;
    }
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

// The floor of a durable audit record: one INSERT of an audit-sized row in its own IMMEDIATE
// transaction on a prepared statement, in WAL mode with synchronous=NORMAL as storage/db.cpp opens
// the gateway's database (no hash chain, no retention, no JSON). What an accepted command cannot
// go below while its record must be durable before the reply leaves.
std::vector<double> MeasureBareInsert(const std::string& path, int n) {
  sqlite3* db = nullptr;
  auto check = [&](int rc, const char* what) {
    if (rc != SQLITE_OK && rc != SQLITE_DONE) {
      std::fprintf(stderr, "sqlite %s: %s\n", what, sqlite3_errmsg(db));
      std::exit(1);
    }
  };
  check(sqlite3_open(path.c_str(), &db), "open");
  check(
      sqlite3_exec(db,
                   "PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;"
                   "CREATE TABLE IF NOT EXISTS t (id INTEGER PRIMARY KEY, ts TEXT, principal TEXT,"
                   " drive TEXT, action TEXT, request TEXT, code INTEGER, message TEXT)",
                   nullptr, nullptr, nullptr),
      "schema");
  sqlite3_stmt* insert = nullptr;
  check(sqlite3_prepare_v2(db,
                           "INSERT INTO t (ts, principal, drive, action, request, code, message)"
                           " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)",
                           -1, &insert, nullptr),
        "prepare");
  const std::string request =
      R"({"name":"drives/x1","position_mm":40,"velocity_mm_s":1000,"acceleration_mm_s2":10000})";
  std::vector<double> us;
  for (int i = 0; i < n + 50; ++i) {
    const auto t0 = Clock::now();
    check(sqlite3_exec(db, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr), "begin");
    sqlite3_bind_text(insert, 1, "2026-11-27T18:00:00.000000Z", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert, 2, "anonymous", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert, 3, "x1", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert, 4, "MoveAbsolute", -1, SQLITE_STATIC);
    sqlite3_bind_text(insert, 5, request.c_str(), -1, SQLITE_STATIC);
    sqlite3_bind_int(insert, 6, 0);
    sqlite3_bind_text(insert, 7, "", -1, SQLITE_STATIC);
    check(sqlite3_step(insert), "insert");
    sqlite3_reset(insert);
    check(sqlite3_exec(db, "COMMIT", nullptr, nullptr, nullptr), "commit");
    const auto t1 = Clock::now();
    if (i >= 50) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  sqlite3_finalize(insert);
  sqlite3_close(db);
  return us;
}

std::string LoadAverage() {
  std::ifstream f("/proc/loadavg");
  std::string one, five, fifteen;
  f >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
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
  // The gateway's drives behind a core without audit log: the audit append's share.
  drivegw::server::DriveServiceCore unaudited((*gw)->core().drives(), nullptr);
  const std::string load_before = LoadAverage();
  // Interleave the measurements in rounds so machine noise hits all of them alike.
  std::vector<double> echo, udp, move, core, bare_core, get, insert, noop, core_async;
  drivegw::server::WorkerPool bench_pool(2);  // the gateway's own pool size is not exported
  const std::string insert_db = std::string(tmpl) + "/bare_insert.db";
  const int rounds = 4;
  auto append = [](std::vector<double>& to, const std::vector<double>& from) {
    to.insert(to.end(), from.begin(), from.end());
  };
  for (int r = 0; r < rounds; ++r) {
    append(echo, MeasureGrpcEcho(n / rounds));
    append(udp, MeasureUdpRoundTrip(*(*gw)->demo_simulator("x2"), n / rounds));
    append(move, MeasureMoveAck(**gw, n / rounds));
    append(get, MeasureGetCommand(**gw, n / rounds));
    append(noop, MeasureOffloadedNoop(**gw, n / rounds));
    append(insert, MeasureBareInsert(insert_db, n / rounds));
    append(core, MeasureCoreMoveAck((*gw)->core(), n / rounds));
    append(bare_core, MeasureCoreMoveAck(unaudited, n / rounds));
    // Over the unaudited core: no extra audit rows that would slow the next round's gateway row
    // (the audit append's share is the two core-direct rows' difference).
    append(core_async, MeasureCoreAsyncMoveAck(unaudited, bench_pool, n / rounds));
  }
  bench_pool.Shutdown();
  const Stats se = Summarize(echo), su = Summarize(udp), sm = Summarize(move), sc = Summarize(core),
              sb = Summarize(bare_core), sg = Summarize(get), si = Summarize(insert),
              sn = Summarize(noop), sa = Summarize(core_async);
  std::printf("%-38s %10s %10s\n", "measurement (n per row)", "p50 us", "p99 us");
  std::printf("%-38s %10.1f %10.1f\n", "baseline: bare gRPC unary echo", se.p50_us, se.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "baseline: bare LinUDP round trip", su.p50_us, su.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "baseline sum (echo + round trip)", se.p50_us + su.p50_us,
              se.p99_us + su.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "MoveAbsolute acknowledged (gateway)", sm.p50_us, sm.p99_us);
  const Stats s_to = Summarize(g_to_created), s_from = Summarize(g_from_created);
  std::printf("%-38s %10.1f %10.1f\n", "  call sent -> command created", s_to.p50_us, s_to.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "  command created -> reply received", s_from.p50_us,
              s_from.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "GetCommand on the gateway (inline)", sg.p50_us, sg.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "NotFound via the worker pool (offload)", sn.p50_us,
              sn.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "  of which without gRPC (core direct)", sc.p50_us,
              sc.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "  core direct without audit append", sb.p50_us, sb.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "  core async without audit (pool hop)", sa.p50_us,
              sa.p99_us);
  std::printf("%-38s %10.1f %10.1f\n", "bare SQLite INSERT+COMMIT (WAL, NORMAL)", si.p50_us,
              si.p99_us);
  // The floor: both baselines plus the durable record the gateway must write before replying.
  const double floor_p50 = (se.p50_us + su.p50_us + si.p50_us) / (se.p50_us + su.p50_us);
  std::printf("floor ratio p50 (echo + round trip + bare insert) / baseline: %.2f\n", floor_p50);
  const double ratio_p50 = sm.p50_us / (se.p50_us + su.p50_us);
  const double ratio_p99 = sm.p99_us / (se.p99_us + su.p99_us);
  const size_t attempted = move.size() + core.size() + bare_core.size() + core_async.size() +
                           static_cast<size_t>(g_errors);
  std::printf("ratio p50 %.2f  p99 %.2f  (target <= 1.3), n=%zu\n", ratio_p50, ratio_p99,
              move.size());
  std::printf("failed moves: %d of %zu\n", g_errors, attempted);
  const std::string load_after = LoadAverage();
  std::printf("load average before %s, after %s\n", load_before.c_str(), load_after.c_str());
  const nlohmann::json detail = {{"echo_p50_us", se.p50_us},
                                 {"echo_p99_us", se.p99_us},
                                 {"udp_p50_us", su.p50_us},
                                 {"udp_p99_us", su.p99_us},
                                 {"gateway_p50_us", sm.p50_us},
                                 {"gateway_p99_us", sm.p99_us},
                                 {"core_p50_us", sc.p50_us},
                                 {"core_p99_us", sc.p99_us},
                                 {"core_no_audit_p50_us", sb.p50_us},
                                 {"core_no_audit_p99_us", sb.p99_us},
                                 {"core_async_no_audit_p50_us", sa.p50_us},
                                 {"core_async_no_audit_p99_us", sa.p99_us},
                                 {"to_created_p50_us", s_to.p50_us},
                                 {"to_created_p99_us", s_to.p99_us},
                                 {"from_created_p50_us", s_from.p50_us},
                                 {"from_created_p99_us", s_from.p99_us},
                                 {"get_command_p50_us", sg.p50_us},
                                 {"get_command_p99_us", sg.p99_us},
                                 {"offload_noop_p50_us", sn.p50_us},
                                 {"offload_noop_p99_us", sn.p99_us},
                                 {"bare_insert_p50_us", si.p50_us},
                                 {"bare_insert_p99_us", si.p99_us},
                                 {"floor_ratio_p50", floor_p50},
                                 {"n", move.size()},
                                 {"failed", g_errors},
                                 {"loadavg_before", load_before},
                                 {"loadavg_after", load_after}};
  const std::string baseline = "bare gRPC unary echo + bare LinUDP round trip (same run)";
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_p50", ratio_p50, "ratio", "<=1.3", baseline, detail});
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_p99", ratio_p99, "ratio", "<=1.3", baseline, detail});
  (*gw)->Stop();
  std::filesystem::remove_all(tmpl);
  // More than 5 % failures means the measurement is meaningless.
  return g_errors * 20 > static_cast<int>(attempted) ? 1 : 0;
}
