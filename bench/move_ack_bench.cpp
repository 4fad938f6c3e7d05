// MoveAbsolute acknowledged through the gateway (gRPC -> core -> LinUDP session -> simulated
// drive -> count echo), against baselines measured in the same run: a bare gRPC unary echo and
// a bare LinUDP round trip to the same kind of simulated drive. Prints p50/p99 and the ratio
// gateway / (gRPC echo + UDP round trip); target ≤ 1.3 (issue 10 P1, docs/performance.md).
// Also splits the gateway's time: at the command's creation, the core without gRPC (blocking and,
// decision 1301, asynchronous), and the core without its audit append, so that the table shows
// where the microseconds beyond the baselines go. Composed baselines (decision 1433) put the two
// baselines together as any acknowledged move must: the round trip inside the echo's handler,
// inline or handed over to an I/O thread, and with a durable insert before the reply. Every row
// prints the process's CPU time and context switches per call (getrusage).
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <string>
#include <thread>
#include <vector>

#include "bench/composed_echo.h"
#include "bench/report.h"
#include "bench/timed_calls.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/gateway.h"
#include "server/grpc/worker_pool.h"
#include "sim/linmot/server.h"

namespace {

using drivegw::bench::Row;
using drivegw::bench::TimeCalls;
using drivegw::server::Gateway;

int g_errors = 0;  // failed moves (time-outs), reported with the results
// The gateway row split at the handle's create_time (the drive's StartCommand; both clocks are
// this process's system clock): call sent -> command created, command created -> reply received.
std::vector<double> g_to_created, g_from_created;
// The composed rows' steps timed inside the echo's handler (warm-up included): what each bare
// part costs when composed, against the same part alone in a tight loop.
std::vector<double> g_inline_rt_in_handler, g_handed_rt_in_handler, g_insert_in_handler;

// Runs `step` and appends its wall time in µs to `to`.
template <typename Step>
void TimeStep(std::vector<double>& to, Step step) {
  const auto t0 = std::chrono::steady_clock::now();
  step();
  to.push_back(
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
}

// Bare gRPC unary echo (callback generic service, same payload size as a MoveAbsoluteRequest);
// `before_reply` runs in its handler on gRPC's callback thread (the composed baselines).
Row MeasureGrpcEcho(int n, std::function<void()> before_reply = {}) {
  drivegw::bench::EchoService echo(std::move(before_reply));
  grpc::ServerBuilder b;
  int port = 0;
  b.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  b.RegisterCallbackGenericService(&echo);
  auto server = b.BuildAndStart();
  auto channel =
      grpc::CreateChannel("127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials());
  grpc::GenericStub stub(channel);
  drivegw::v1::MoveAbsoluteRequest req;
  req.set_name("drives/x1");
  req.set_position_mm(40);
  req.set_velocity_mm_s(1000);
  req.set_acceleration_mm_s2(10000);
  const std::string bytes = req.SerializeAsString();
  Row row = TimeCalls(n, [&](int) {
    grpc::Slice slice(bytes);
    grpc::ByteBuffer in(&slice, 1), out;
    grpc::ClientContext ctx;
    std::promise<grpc::Status> done;
    stub.UnaryCall(&ctx, "/bench.Echo/Echo", grpc::StubOptions(), &in, &out,
                   [&](grpc::Status s) { done.set_value(s); });
    const grpc::Status s = done.get_future().get();
    if (!s.ok()) drivegw::bench::Die("echo failed: " + s.error_message());
    return true;
  });
  server->Shutdown();
  return row;
}

// Bare LinUDP round trip: a status poll (linmot-linudp.md §9 telegram 1) to a simulated drive.
Row MeasureUdpRoundTrip(drivegw::transport::Endpoint drive, int n) {
  drivegw::bench::InlineRoundTrip rt(drive);
  return TimeCalls(n, [&](int) {
    rt.Run();
    return true;
  });
}

// Composed (a): the echo whose handler does the bare round trip itself, on gRPC's thread.
Row MeasureEchoInlineRoundTrip(drivegw::transport::Endpoint drive, int n) {
  drivegw::bench::InlineRoundTrip rt(drive);
  return MeasureGrpcEcho(n, [&] { TimeStep(g_inline_rt_in_handler, [&] { rt.Run(); }); });
}

// Composed (b): the round trip handed over to an I/O thread as the gateway's session does.
Row MeasureEchoHandedOverRoundTrip(drivegw::transport::Endpoint drive, int n) {
  drivegw::bench::HandedOverRoundTrip rt(drive);
  return MeasureGrpcEcho(n, [&] { TimeStep(g_handed_rt_in_handler, [&] { rt.Run(); }); });
}

// Composed (c): (b) plus a bare durable INSERT+COMMIT before the reply (decision 017's order).
Row MeasureEchoHandedOverAudited(drivegw::transport::Endpoint drive, const std::string& db, int n) {
  drivegw::bench::HandedOverRoundTrip rt(drive);
  drivegw::bench::BareAuditInsert audit(db);
  return MeasureGrpcEcho(n, [&] {
    rt.Run();
    TimeStep(g_insert_in_handler, [&] { audit.Commit(); });
  });
}

Row MeasureMoveAck(Gateway& gw, int n) {
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
  return TimeCalls(n, [&](int i) {
    drivegw::v1::MoveAbsoluteRequest req;
    req.set_name("drives/x1");
    req.set_position_mm(i % 2 == 0 ? 40 : 60);
    req.set_velocity_mm_s(1000);
    req.set_acceleration_mm_s2(10000);
    drivegw::v1::CommandHandle h;
    grpc::ClientContext ctx;
    const auto w0 = std::chrono::system_clock::now();
    grpc::Status s = stub->MoveAbsolute(&ctx, req, &h);
    const auto w1 = std::chrono::system_clock::now();
    if (!s.ok()) {
      // A loaded machine can miss the 100 ms acceptance time-out (D-11); count, do not die.
      ++g_errors;
      std::fprintf(stderr, "move %d failed: %s\n", i, s.error_message().c_str());
      return false;
    }
    if (i < drivegw::bench::kWarmupCalls) return true;
    const auto created = std::chrono::system_clock::time_point(
        std::chrono::seconds(h.create_time().seconds()) +
        std::chrono::duration_cast<std::chrono::system_clock::duration>(
            std::chrono::nanoseconds(h.create_time().nanos())));
    g_to_created.push_back(std::chrono::duration<double, std::micro>(created - w0).count());
    g_from_created.push_back(std::chrono::duration<double, std::micro>(w1 - created).count());
    return true;
  });
}

// Times n unary calls (after the warm-up) on a fresh DriveService channel to the gateway; `call`
// makes one call with the given context and must return `want`, or the bench stops.
template <typename Call>
Row TimeGatewayCalls(Gateway& gw, int n, grpc::StatusCode want, const char* what, Call call) {
  auto channel = grpc::CreateChannel("127.0.0.1:" + std::to_string(gw.grpc_port()),
                                     grpc::InsecureChannelCredentials());
  auto stub = drivegw::v1::DriveService::NewStub(channel);
  return TimeCalls(n, [&](int) {
    grpc::ClientContext ctx;
    const grpc::Status s = call(*stub, ctx);
    if (s.error_code() != want) {
      std::fprintf(stderr, "%s: want code %d, got %d %s\n", what, want, s.error_code(),
                   s.error_message().c_str());
      std::exit(1);
    }
    return true;
  });
}

// A cheap unary call on the gateway's own gRPC server, run inline on gRPC's thread: GetCommand
// of the last move's handle. Its excess over the bare echo is the server's per-call overhead
// (interceptor, authorisation, the larger service).
Row MeasureGetCommand(Gateway& gw, int n) {
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
Row MeasureOffloadedNoop(Gateway& gw, int n) {
  drivegw::v1::ReadParameterRequest req;
  req.set_name("drives/not-configured");
  req.set_parameter_id(0x1450);
  drivegw::v1::Parameter p;
  return TimeGatewayCalls(gw, n, grpc::StatusCode::NOT_FOUND, "ReadParameter",
                          [&](drivegw::v1::DriveService::Stub& stub, grpc::ClientContext& ctx) {
                            return stub.ReadParameter(&ctx, req, &p);
                          });
}

drivegw::v1::MoveAbsoluteRequest AlternatingMove(int i) {
  drivegw::v1::MoveAbsoluteRequest req;
  req.set_name("drives/x1");
  req.set_position_mm(i % 2 == 0 ? 40 : 60);
  req.set_velocity_mm_s(1000);
  req.set_acceleration_mm_s2(10000);
  return req;
}

// The same call without gRPC: the core's MoveAbsolute straight into the drive and the session,
// to split the gateway's own cost from the gRPC hop. `core` is the gateway's (with its audit
// log) or one over the same drives without audit (audit = null), to split the audit append off.
Row MeasureCoreMoveAck(drivegw::server::DriveServiceCore& core, int n) {
  drivegw::server::CallContext cc;
  return TimeCalls(n, [&](int i) {
    auto h = core.MoveAbsolute(AlternatingMove(i), cc);
    if (!h.ok()) {
      ++g_errors;
      std::fprintf(stderr, "core move %d failed: %s\n", i,
                   std::string(h.status().message()).c_str());
      return false;
    }
    return true;
  });
}

// The asynchronous core path the gRPC MoveAbsolute now takes (decision 1301), without gRPC and
// (called with the unaudited core) without the audit append: MoveAbsoluteAsync from the bench
// thread (which sends the telegram when the line is free), the reply evaluated on the session's
// I/O thread, the completion on a pool thread. Its excess over "core direct without audit
// append" is the price of the pool hop against the blocked caller's condition variable.
Row MeasureCoreAsyncMoveAck(drivegw::server::DriveServiceCore& core,
                            drivegw::server::WorkerPool& pool, int n) {
  drivegw::server::CallContext cc;
  return TimeCalls(n, [&](int i) {
    std::promise<absl::Status> done;
    core.MoveAbsoluteAsync(
        AlternatingMove(i), cc, pool,
        [&](absl::StatusOr<drivegw::v1::CommandHandle> h) { done.set_value(h.status()); });
    const absl::Status s = done.get_future().get();
    if (!s.ok()) {
      ++g_errors;
      std::fprintf(stderr, "core async move %d failed: %s\n", i, std::string(s.message()).c_str());
      return false;
    }
    return true;
  });
}

// The floor of a durable audit record alone (BareAuditInsert), in the bench's thread.
Row MeasureBareInsert(const std::string& path, int n) {
  drivegw::bench::BareAuditInsert audit(path);
  return TimeCalls(n, [&](int) {
    audit.Commit();
    return true;
  });
}

// The process's CPU while the bench waits: the demo's other drives and simulators (cyclic polls),
// which every row's CPU per call includes for its wall time.
drivegw::bench::Usage MeasureIdle() {
  const auto before = drivegw::bench::Usage::Now();
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  return drivegw::bench::Usage::Now() - before;
}

std::string LoadAverage() {
  std::ifstream f("/proc/loadavg");
  std::string one, five, fifteen;
  f >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

void PrintRow(const char* label, const Row& row) {
  const auto s = drivegw::bench::Summarize(row.us);
  std::printf("%-42s %9.1f %9.1f %9.1f %7.1f\n", label, s.p50_us, s.p99_us, row.CpuUsPerCall(),
              row.SwitchesPerCall());
}

}  // namespace

int main(int argc, char** argv) {
  using drivegw::bench::Summarize;
  const int n = argc > 1 ? std::atoi(argv[1]) : 2000;
  // Optional: a comma-separated list of the rows to run (the keys of cpu_us_per_call in the
  // detail), for profiling one row alone (perf record); such a run prints no @result line.
  const std::string only = argc > 2 ? argv[2] : "";
  auto want = [&](const char* key) {
    return only.empty() ||
           ("," + only + ",").find("," + std::string(key) + ",") != std::string::npos;
  };
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
  // The baselines talk to the simulator of the demo's second LinMot drive (the moves go to x1).
  const drivegw::transport::Endpoint sim = (*gw)->demo_simulator("x2")->endpoint();
  const std::string load_before = LoadAverage();
  // Interleave the measurements in rounds so machine noise hits all of them alike.
  Row echo, udp, echo_inline_rt, echo_handed_rt, echo_audited, move, core, bare_core, get, insert,
      noop, core_async;
  drivegw::bench::Usage idle;
  drivegw::server::WorkerPool bench_pool(2);  // the gateway's own pool size is not exported
  const std::string insert_db = std::string(tmpl) + "/bare_insert.db";
  const std::string composed_db = std::string(tmpl) + "/composed_insert.db";
  const int rounds = 4;
  for (int r = 0; r < rounds; ++r) {
    const int k = n / rounds;
    idle += MeasureIdle();
    if (want("echo")) echo += MeasureGrpcEcho(k);
    if (want("udp")) udp += MeasureUdpRoundTrip(sim, k);
    if (want("composed_inline")) echo_inline_rt += MeasureEchoInlineRoundTrip(sim, k);
    if (want("composed_handed_over")) echo_handed_rt += MeasureEchoHandedOverRoundTrip(sim, k);
    if (want("composed_audited")) echo_audited += MeasureEchoHandedOverAudited(sim, composed_db, k);
    if (want("gateway")) move += MeasureMoveAck(**gw, k);
    if (want("get_command")) get += MeasureGetCommand(**gw, k);
    if (want("offload_noop")) noop += MeasureOffloadedNoop(**gw, k);
    if (want("bare_insert")) insert += MeasureBareInsert(insert_db, k);
    if (want("core")) core += MeasureCoreMoveAck((*gw)->core(), k);
    if (want("core_no_audit")) bare_core += MeasureCoreMoveAck(unaudited, k);
    // Over the unaudited core: no extra audit rows that would slow the next round's gateway row
    // (the audit append's share is the two core-direct rows' difference).
    if (want("core_async_no_audit")) {
      core_async += MeasureCoreAsyncMoveAck(unaudited, bench_pool, k);
    }
  }
  bench_pool.Shutdown();
  const auto se = Summarize(echo.us), su = Summarize(udp.us), sm = Summarize(move.us),
             sc = Summarize(core.us), sb = Summarize(bare_core.us), sg = Summarize(get.us),
             si = Summarize(insert.us), sn = Summarize(noop.us), sa = Summarize(core_async.us),
             sci = Summarize(echo_inline_rt.us), sch = Summarize(echo_handed_rt.us),
             scc = Summarize(echo_audited.us);
  std::printf("%-42s %9s %9s %9s %7s\n", "measurement (n per row)", "p50 us", "p99 us", "CPU us",
              "cs");
  PrintRow("baseline: bare gRPC unary echo", echo);
  PrintRow("baseline: bare LinUDP round trip", udp);
  std::printf("%-42s %9.1f %9.1f %9.1f\n", "baseline sum (echo + round trip)",
              se.p50_us + su.p50_us, se.p99_us + su.p99_us,
              echo.CpuUsPerCall() + udp.CpuUsPerCall());
  const auto s_irt = Summarize(g_inline_rt_in_handler), s_hrt = Summarize(g_handed_rt_in_handler),
             s_ins = Summarize(g_insert_in_handler);
  PrintRow("composed (a): echo + inline round trip", echo_inline_rt);
  std::printf("%-42s %9.1f %9.1f\n", "  round trip inside the handler", s_irt.p50_us, s_irt.p99_us);
  PrintRow("composed (b): echo + handed-over trip", echo_handed_rt);
  std::printf("%-42s %9.1f %9.1f\n", "  round trip inside the handler", s_hrt.p50_us, s_hrt.p99_us);
  PrintRow("composed (c): (b) + bare INSERT+COMMIT", echo_audited);
  std::printf("%-42s %9.1f %9.1f\n", "  INSERT+COMMIT inside the handler", s_ins.p50_us,
              s_ins.p99_us);
  PrintRow("MoveAbsolute acknowledged (gateway)", move);
  const auto s_to = Summarize(g_to_created), s_from = Summarize(g_from_created);
  std::printf("%-42s %9.1f %9.1f\n", "  call sent -> command created", s_to.p50_us, s_to.p99_us);
  std::printf("%-42s %9.1f %9.1f\n", "  command created -> reply received", s_from.p50_us,
              s_from.p99_us);
  PrintRow("GetCommand on the gateway (inline)", get);
  PrintRow("NotFound via the worker pool (offload)", noop);
  PrintRow("  of which without gRPC (core direct)", core);
  PrintRow("  core direct without audit append", bare_core);
  PrintRow("  core async without audit (pool hop)", core_async);
  PrintRow("bare SQLite INSERT+COMMIT (WAL, NORMAL)", insert);
  const double idle_cpu_pct = idle.wall_s > 0 ? 100.0 * idle.cpu_s / idle.wall_s : 0;
  std::printf(
      "(CPU us = the whole process's CPU per call, getrusage; cs = context switches per "
      "call; idle process: %.1f %% of a core, included in every row)\n",
      idle_cpu_pct);
  // The floor: both baselines plus the durable record the gateway must write before replying.
  const double base_p50 = se.p50_us + su.p50_us, base_p99 = se.p99_us + su.p99_us;
  const double floor_p50 = (base_p50 + si.p50_us) / base_p50;
  std::printf("floor ratio p50 (echo + round trip + bare insert) / baseline: %.2f\n", floor_p50);
  const double composed_p50 = scc.p50_us / base_p50, composed_p99 = scc.p99_us / base_p99;
  std::printf("composed / baseline: (a) p50 %.2f  (b) p50 %.2f  (c) p50 %.2f p99 %.2f\n",
              sci.p50_us / base_p50, sch.p50_us / base_p50, composed_p50, composed_p99);
  const double to_composed_p50 = sm.p50_us / scc.p50_us, to_composed_p99 = sm.p99_us / scc.p99_us;
  std::printf("gateway / composed (c): p50 %.2f  p99 %.2f  CPU %.2f\n", to_composed_p50,
              to_composed_p99, move.CpuUsPerCall() / echo_audited.CpuUsPerCall());
  const double ratio_p50 = sm.p50_us / base_p50;
  const double ratio_p99 = sm.p99_us / base_p99;
  const size_t attempted = move.us.size() + core.us.size() + bare_core.us.size() +
                           core_async.us.size() + static_cast<size_t>(g_errors);
  std::printf("ratio p50 %.2f  p99 %.2f  (target <= 1.3), n=%zu\n", ratio_p50, ratio_p99,
              move.us.size());
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
                                 {"composed_inline_p50_us", sci.p50_us},
                                 {"composed_inline_p99_us", sci.p99_us},
                                 {"composed_handed_over_p50_us", sch.p50_us},
                                 {"composed_handed_over_p99_us", sch.p99_us},
                                 {"composed_audited_p50_us", scc.p50_us},
                                 {"composed_audited_p99_us", scc.p99_us},
                                 {"inline_rt_in_handler_p50_us", s_irt.p50_us},
                                 {"handed_rt_in_handler_p50_us", s_hrt.p50_us},
                                 {"insert_in_handler_p50_us", s_ins.p50_us},
                                 {"cpu_us_per_call",
                                  {{"echo", echo.CpuUsPerCall()},
                                   {"udp", udp.CpuUsPerCall()},
                                   {"composed_inline", echo_inline_rt.CpuUsPerCall()},
                                   {"composed_handed_over", echo_handed_rt.CpuUsPerCall()},
                                   {"composed_audited", echo_audited.CpuUsPerCall()},
                                   {"gateway", move.CpuUsPerCall()},
                                   {"get_command", get.CpuUsPerCall()},
                                   {"offload_noop", noop.CpuUsPerCall()},
                                   {"core", core.CpuUsPerCall()},
                                   {"core_no_audit", bare_core.CpuUsPerCall()},
                                   {"core_async_no_audit", core_async.CpuUsPerCall()},
                                   {"bare_insert", insert.CpuUsPerCall()}}},
                                 {"idle_cpu_pct", idle_cpu_pct},
                                 {"floor_ratio_p50", floor_p50},
                                 {"n", move.us.size()},
                                 {"failed", g_errors},
                                 {"loadavg_before", load_before},
                                 {"loadavg_after", load_after}};
  if (!only.empty()) {
    std::printf("rows limited to %s: no @result lines\n", only.c_str());
    (*gw)->Stop();
    std::filesystem::remove_all(tmpl);
    return 0;
  }
  const std::string baseline = "bare gRPC unary echo + bare LinUDP round trip (same run)";
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_p50", ratio_p50, "ratio", "<=1.3", baseline, detail});
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_p99", ratio_p99, "ratio", "<=1.3", baseline, detail});
  // Informational (decision 1433): the composed floor against the baseline, and the
  // gateway against that floor.
  const std::string composed =
      "bare echo whose handler hands a bare LinUDP round trip to an I/O thread and commits a bare "
      "durable INSERT before replying (same run)";
  drivegw::bench::Report({"P1", "composed_ratio_p50", composed_p50, "ratio", "", baseline, {}});
  drivegw::bench::Report({"P1", "composed_ratio_p99", composed_p99, "ratio", "", baseline, {}});
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_to_composed_p50", to_composed_p50, "ratio", "", composed, {}});
  drivegw::bench::Report(
      {"P1", "move_ack_ratio_to_composed_p99", to_composed_p99, "ratio", "", composed, {}});
  (*gw)->Stop();
  std::filesystem::remove_all(tmpl);
  // More than 5 % failures means the measurement is meaningless.
  return g_errors * 20 > static_cast<int>(attempted) ? 1 : 0;
}
