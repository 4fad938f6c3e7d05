// The demo gateway in a benchmark's own process (ephemeral gRPC, HTTP and drive ports, a CAN bus
// of its own, a temporary data directory removed at the end), and the process numbers benchmarks
// report beside their ratios: load average and CPU time.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>

#include "server/gateway.h"

namespace drivegw::bench {

class DemoGateway {
 public:
  // Exits with a message when the gateway does not start (a benchmark has nothing to measure).
  // `rest_direct_reads`: GatewayOptions::rest_direct_reads (decision 1331); `can_offset` moves
  // the CAN buses off a gateway started before in the same process.
  explicit DemoGateway(bool rest_direct_reads = true, uint16_t can_offset = 0) {
    char tmpl[] = "/tmp/drivegw-bench-XXXXXX";
    if (::mkdtemp(tmpl) == nullptr) std::exit(1);
    dir_ = tmpl;
    server::GatewayOptions o;
    o.config.listen.grpc = "127.0.0.1:0";
    o.config.listen.http = "127.0.0.1:0";
    o.config.data_dir = dir_;
    o.demo_first_port = 0;
    o.demo_master_port = 0;
    o.demo_can_port =  // a bus of its own
        static_cast<uint16_t>(20000 + ::getpid() % 20000 + can_offset);
    o.rest_direct_reads = rest_direct_reads;
    auto gw = server::Gateway::Start(std::move(o));
    if (!gw.ok()) {
      std::fprintf(stderr, "gateway: %s\n", std::string(gw.status().message()).c_str());
      std::exit(1);
    }
    gateway_ = *std::move(gw);
  }
  ~DemoGateway() { Stop(); }
  DemoGateway(const DemoGateway&) = delete;
  DemoGateway& operator=(const DemoGateway&) = delete;

  server::Gateway& operator*() { return *gateway_; }
  server::Gateway* operator->() { return gateway_.get(); }

  void Stop() {
    if (gateway_ == nullptr) return;
    gateway_->Stop();
    gateway_.reset();
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }

 private:
  std::string dir_;
  std::unique_ptr<server::Gateway> gateway_;
};

// The 1-minute load average (/proc/loadavg), printed with every number (docs/performance.md).
inline double LoadAverage() {
  double l = 0;
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &l) != 1) l = 0;
    std::fclose(f);
  }
  return l;
}

// User + system CPU seconds of the whole process so far.
inline double ProcessCpuSeconds() {
  rusage u{};
  ::getrusage(RUSAGE_SELF, &u);
  auto s = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return s(u.ru_utime) + s(u.ru_stime);
}

}  // namespace drivegw::bench
