// P5 (issue 10): N concurrent gRPC WatchDrives streams (drive x1, max_rate_hz 100) on the gateway
// against the same N streams from a bare callback server-streaming service that sends an empty
// payload at the same rate (the same serving mechanism: WatchServing's shared ticker, reactor and
// raw byte writes, decision 1341; a grpc::Server of its own in this process). One client for both:
// C channels (own connections), one generic callback reactor per stream that counts messages and
// records their arrival times without parsing them (the first one of each gateway stream is parsed
// to check it is x1's status).
//
// WatchDrives sends a drive's snapshot only when it changed, at most max_rate_hz times a second,
// latest snapshot wins (core WatchDrives; decision 504 item 5). x1 is kept moving for the whole run
// (its LinUDP cycle is 5 ms, so it has a new snapshot at every 10 ms tick), so a stream that keeps
// up receives 100 messages/s. A stream "falls behind" when, within the measuring window, it got
// fewer than 95 % of rate x window messages or two consecutive messages were more than 100 ms apart
// (10 periods: coalescing hides a slow stream as missing messages, never as a queue).
// Run: build/bench/watch_streams_bench [streams = 1000] [seconds = 5] [rounds = 2] [channels = 4]
#include <grpcpp/generic/generic_stub.h>
#include <grpcpp/grpcpp.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "bench/demo_gateway.h"
#include "bench/report.h"
#include "drivegw/v1/drive.grpc.pb.h"
#include "server/core/drive_service.h"
#include "server/gateway.h"
#include "server/grpc/watch_reactor.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace std::chrono_literals;

constexpr double kRateHz = 100;
constexpr auto kMaxGap = 100ms;
constexpr double kMinShare = 0.95;
const char* const kMethod = "/drivegw.v1.DriveService/WatchDrives";

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "watch_streams_bench: %s\n", what.c_str());
  std::exit(1);
}

// --- baseline: empty payload at 100 Hz through the same reactor --------------------------------

// Every tick yields the same shared empty DriveStatus: no drive, no conversion, no change check.
class EmptySource final : public drivegw::server::WatchSource {
 public:
  explicit EmptySource(drivegw::server::SharedDriveStatus empty) : empty_(std::move(empty)) {}
  void Next(std::vector<drivegw::server::SharedDriveStatus>& out) override {
    out.push_back(empty_);
  }
  bool Ended() const noexcept override { return false; }

 private:
  drivegw::server::SharedDriveStatus empty_;
};

class EmptyWatchService final : public drivegw::v1::DriveService::WithRawCallbackMethod_WatchDrives<
                                    drivegw::v1::DriveService::CallbackService> {
  grpc::ServerWriteReactor<grpc::ByteBuffer>* WatchDrives(grpc::CallbackServerContext*,
                                                          const grpc::ByteBuffer* raw) override {
    auto req = drivegw::server::ParseWatchRequest(*raw);
    if (!req.ok()) return serving_.Start(req.status());
    const auto period = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(1.0 / std::max(req->max_rate_hz(), 1.0)));
    return serving_.Start(drivegw::server::DriveServiceCore::OpenedWatch{
        std::make_unique<EmptySource>(empty_), period});
  }

  const drivegw::server::SharedDriveStatus empty_ =
      std::make_shared<const drivegw::v1::DriveStatus>();
  // The gateway's serving mechanism: shared ticker, one write in flight, shared wire bytes.
  drivegw::server::WatchServing serving_;
};

// --- client --------------------------------------------------------------------------------------

struct Done {
  std::mutex mu;
  std::condition_variable cv;
  int count = 0;
};

class Watcher final : public grpc::ClientBidiReactor<grpc::ByteBuffer, grpc::ByteBuffer> {
 public:
  Watcher(const grpc::ByteBuffer& request, size_t expected, Done& done)
      : request_(request), done_(done) {
    arrivals_.reserve(expected);
  }
  void Start(grpc::GenericStub& stub) {
    stub.PrepareBidiStreamingCall(&ctx_, kMethod, grpc::StubOptions(), this);
    StartWrite(&request_);
    StartRead(&in_);
    StartCall();
  }
  void Cancel() { ctx_.TryCancel(); }

  void OnWriteDone(bool ok) override {
    if (ok) StartWritesDone();
  }
  void OnReadDone(bool ok) override {
    if (!ok) return;
    arrivals_.push_back(Clock::now());
    bytes_ += in_.Length();
    if (arrivals_.size() == 1) first_ = in_;
    in_.Clear();
    StartRead(&in_);
  }
  void OnDone(const grpc::Status& s) override {
    status_ = s;
    std::lock_guard lock(done_.mu);
    ++done_.count;
    done_.cv.notify_all();
  }

  const std::vector<Clock::time_point>& arrivals() const { return arrivals_; }
  const grpc::ByteBuffer& first() const { return first_; }
  const grpc::Status& status() const { return status_; }
  size_t bytes() const { return bytes_; }

 private:
  grpc::ClientContext ctx_;
  grpc::ByteBuffer request_, in_, first_;
  Done& done_;
  std::vector<Clock::time_point> arrivals_;  // touched by gRPC threads only until OnDone
  size_t bytes_ = 0;
  grpc::Status status_;
};

struct RoundResult {
  double cpu_s = 0;   // process CPU (server, client, x1's drive and simulator) within the window
  long messages = 0;  // within the window, all streams
  int behind = 0;
  int failed = 0;  // streams that ended with an error other than CANCELLED
  double window_s = 0;
  double worst_gap_ms = 0;
  double min_share = 1;  // lowest per-stream count / expected
  double bytes_per_msg = 0;
};

RoundResult RunStreams(uint16_t port, int streams, int channels, double seconds,
                       bool check_status) {
  drivegw::v1::WatchDrivesRequest req;
  req.add_names("drives/x1");
  req.set_max_rate_hz(kRateHz);
  const std::string bytes = req.SerializeAsString();
  grpc::Slice slice(bytes);
  const grpc::ByteBuffer request(&slice, 1);

  std::vector<std::unique_ptr<grpc::GenericStub>> stubs;
  for (int c = 0; c < channels; ++c) {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);  // a connection per channel
    args.SetInt("drivegw.bench.channel", c);
    stubs.push_back(std::make_unique<grpc::GenericStub>(grpc::CreateCustomChannel(
        "127.0.0.1:" + std::to_string(port), grpc::InsecureChannelCredentials(), args)));
  }
  const auto warmup = 1s;
  const size_t expected = static_cast<size_t>(kRateHz * (seconds + 3) * 1.2);
  Done done;
  std::vector<std::unique_ptr<Watcher>> watchers;
  for (int i = 0; i < streams; ++i) {
    watchers.push_back(std::make_unique<Watcher>(request, expected, done));
    watchers.back()->Start(*stubs[static_cast<size_t>(i % channels)]);
  }
  const auto t0 = Clock::now() + warmup;
  const auto t1 =
      t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::this_thread::sleep_until(t0);
  const double cpu0 = drivegw::bench::ProcessCpuSeconds();
  std::this_thread::sleep_until(t1);
  const double cpu1 = drivegw::bench::ProcessCpuSeconds();
  std::this_thread::sleep_until(t1 + 50ms);
  for (auto& w : watchers) w->Cancel();
  {
    std::unique_lock lock(done.mu);
    if (!done.cv.wait_for(lock, 60s, [&] { return done.count == streams; }))
      Die("streams did not end");
  }

  RoundResult r;
  r.window_s = seconds;
  r.cpu_s = cpu1 - cpu0;
  const double want = kRateHz * seconds;
  size_t bytes_total = 0, msgs_total = 0;
  for (auto& w : watchers) {
    if (!w->status().ok() && w->status().error_code() != grpc::StatusCode::CANCELLED) {
      if (r.failed++ == 0)
        std::fprintf(stderr, "stream failed: %s\n", w->status().error_message().c_str());
    }
    long n = 0;
    auto prev = t0;
    Clock::duration worst{0};
    for (const auto& t : w->arrivals()) {
      if (t < t0) continue;
      if (t >= t1) break;
      ++n;
      worst = std::max(worst, t - prev);
      prev = t;
    }
    worst = std::max(worst, t1 - prev);
    const double gap_ms = std::chrono::duration<double, std::milli>(worst).count();
    r.worst_gap_ms = std::max(r.worst_gap_ms, gap_ms);
    r.min_share = std::min(r.min_share, static_cast<double>(n) / want);
    if (static_cast<double>(n) < kMinShare * want || worst > kMaxGap) ++r.behind;
    r.messages += n;
    bytes_total += w->bytes();
    msgs_total += w->arrivals().size();
    if (check_status && !w->arrivals().empty()) {
      std::vector<grpc::Slice> slices;
      drivegw::v1::DriveStatus s;
      std::string raw;
      if (w->first().Dump(&slices).ok()) {
        for (const auto& sl : slices)
          raw.append(reinterpret_cast<const char*>(sl.begin()), sl.size());
      }
      if (!s.ParseFromString(raw) || s.name().find("x1") == std::string::npos)
        Die("stream did not carry x1's status");
    }
  }
  r.bytes_per_msg =
      msgs_total > 0 ? static_cast<double>(bytes_total) / static_cast<double>(msgs_total) : 0;
  return r;
}

// Keeps x1 moving between 20 and 130 mm so that every 10 ms tick has a new snapshot.
class Mover {
 public:
  explicit Mover(drivegw::server::DriveServiceCore& core) : core_(core) {
    drivegw::v1::EnableRequest en;
    en.set_name("drives/x1");
    if (auto h = core_.Enable(en, cc_); !h.ok())
      Die(std::string("enable x1: ") + std::string(h.status().message()));
    thread_ = std::thread([this] { Run(); });
  }
  ~Mover() {
    stop_ = true;
    thread_.join();
  }
  int moves() const { return moves_; }

 private:
  void Run() {
    double target = 130;
    Move(target);
    while (!stop_) {
      std::this_thread::sleep_for(20ms);
      drivegw::v1::GetDriveRequest g;
      g.set_name("drives/x1");
      auto d = core_.GetDrive(g, cc_);
      if (!d.ok()) continue;
      if (std::abs(d->status().position_mm() - target) < 10) {
        target = target > 75 ? 20 : 130;
        Move(target);
      }
    }
  }
  void Move(double target) {
    drivegw::v1::MoveAbsoluteRequest m;
    m.set_name("drives/x1");
    m.set_position_mm(target);
    m.set_velocity_mm_s(100);
    m.set_acceleration_mm_s2(1000);
    if (core_.MoveAbsolute(m, cc_).ok()) ++moves_;
  }

  drivegw::server::DriveServiceCore& core_;
  drivegw::server::CallContext cc_;
  std::atomic<bool> stop_{false};
  std::atomic<int> moves_{0};
  std::thread thread_;
};

void Accumulate(RoundResult& sum, const RoundResult& r) {
  sum.messages += r.messages;
  sum.cpu_s += r.cpu_s;
  sum.behind = std::max(sum.behind, r.behind);  // the worst round
  sum.failed += r.failed;
  sum.window_s += r.window_s;
  sum.worst_gap_ms = std::max(sum.worst_gap_ms, r.worst_gap_ms);
  sum.min_share = std::min(sum.min_share, r.min_share);
  sum.bytes_per_msg = r.bytes_per_msg;
}

}  // namespace

int main(int argc, char** argv) {
  const int streams = argc > 1 ? std::atoi(argv[1]) : 1000;
  const double seconds = argc > 2 ? std::atof(argv[2]) : 5.0;
  const int rounds = argc > 3 ? std::atoi(argv[3]) : 2;
  const int channels = std::max(1, argc > 4 ? std::atoi(argv[4]) : 4);
  drivegw::bench::DemoGateway gw;

  EmptyWatchService empty;
  grpc::ServerBuilder b;
  int bare_port = 0;
  b.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &bare_port);
  b.RegisterService(&empty);
  auto bare = b.BuildAndStart();
  if (!bare) Die("baseline server did not start");

  RoundResult base, gate;
  base.window_s = gate.window_s = 0;
  const double load_before = drivegw::bench::LoadAverage();
  {
    Mover mover(gw->core());
    for (int r = 0; r < rounds; ++r) {
      Accumulate(base,
                 RunStreams(static_cast<uint16_t>(bare_port), streams, channels, seconds, false));
      Accumulate(gate, RunStreams(gw->grpc_port(), streams, channels, seconds, true));
    }
    if (mover.moves() < 2) Die("x1 did not move");
  }
  const double load_after = drivegw::bench::LoadAverage();
  bare->Shutdown(std::chrono::system_clock::now() + 2s);
  gw.Stop();

  const double base_rate =
      base.window_s > 0 ? static_cast<double>(base.messages) / base.window_s : 0;
  const double gate_rate =
      gate.window_s > 0 ? static_cast<double>(gate.messages) / gate.window_s : 0;
  const double ratio = base_rate > 0 ? gate_rate / base_rate : 0;
  const double ideal = kRateHz * streams;
  // Process CPU per delivered message (gateway or baseline server, client, x1's drive and sim):
  // with the per-message cost and the CPU the machine gives this process, what rate can be had.
  auto cpu_us = [](const RoundResult& r) {
    return r.messages > 0 ? 1e6 * r.cpu_s / static_cast<double>(r.messages) : 0;
  };
  auto cores = [](const RoundResult& r) { return r.window_s > 0 ? r.cpu_s / r.window_s : 0; };
  std::printf("P5 WatchDrives: %d streams x %.0f Hz on %d channels, %d x %.1f s windows\n", streams,
              kRateHz, channels, rounds, seconds);
  std::printf("%-40s %11s %8s %8s %10s %9s %7s %9s %6s\n", "measurement", "msgs/s", "of ideal",
              "behind", "worst gap", "min share", "B/msg", "CPU us/m", "cores");
  std::printf("%-40s %11.0f %7.1f%% %8d %8.1fms %8.1f%% %7.0f %9.1f %6.2f\n",
              "baseline: empty payload, same serving", base_rate, 100 * base_rate / ideal,
              base.behind, base.worst_gap_ms, 100 * base.min_share, base.bytes_per_msg,
              cpu_us(base), cores(base));
  std::printf("%-40s %11.0f %7.1f%% %8d %8.1fms %8.1f%% %7.0f %9.1f %6.2f\n",
              "gateway: WatchDrives x1 (moving)", gate_rate, 100 * gate_rate / ideal, gate.behind,
              gate.worst_gap_ms, 100 * gate.min_share, gate.bytes_per_msg, cpu_us(gate),
              cores(gate));
  std::printf(
      "ratio gateway/baseline %.2f (target >= 0.8); streams behind %d (target 0); failed %d; load "
      "%.2f -> %.2f\n",
      ratio, gate.behind, gate.failed + base.failed, load_before, load_after);
  const nlohmann::json detail = {{"gateway_msgs_per_s", gate_rate},
                                 {"baseline_msgs_per_s", base_rate},
                                 {"ideal_msgs_per_s", ideal},
                                 {"streams", streams},
                                 {"channels", channels},
                                 {"window_s", seconds},
                                 {"rounds", rounds},
                                 {"gateway_worst_gap_ms", gate.worst_gap_ms},
                                 {"gateway_min_share", gate.min_share},
                                 {"baseline_behind", base.behind},
                                 {"baseline_worst_gap_ms", base.worst_gap_ms},
                                 {"gateway_bytes_per_msg", gate.bytes_per_msg},
                                 {"gateway_cpu_us_per_msg", cpu_us(gate)},
                                 {"baseline_cpu_us_per_msg", cpu_us(base)},
                                 {"gateway_cores_used", cores(gate)},
                                 {"baseline_cores_used", cores(base)},
                                 {"load_avg", load_after}};
  drivegw::bench::Report({"P5", "watch_streams_ratio", ratio, "ratio", ">=0.8",
                          "same streams, empty payload, same shared ticker and reactor", detail});
  drivegw::bench::Report({"P5", "streams_behind", static_cast<double>(gate.behind), "streams", "=0",
                          "< 95 % of 100 Hz x window or a gap > 100 ms", detail});
  return gate.failed + base.failed == 0 ? 0 : 1;
}
