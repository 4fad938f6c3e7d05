// Applying a parameter set to simulated drives (issue 6) against the bare parameter round trips
// measured in the same run through the same drives. Family: LinMot LinUDP (every Read/Write
// is a real RTC round trip over UDP to the simulated drive, linmot-linudp.md §4.2). The simulator
// has 20 writable UPIDs that change no motion state, so an N-value set cycles through them: value
// i writes UPID i % 20 with (value read at start) + i / 20 + 1, every value differing from the
// drive's (docs/performance.md "Parameter-set apply").
//
// Baseline = Σ over every value of (ReadParameter + WriteParameter), timed call by call.
// Apply = ParameterApplier::Run end to end: catalogue validation, pre-image (one read per UPID),
// write + read back per value, the operation stored in SQLite after every drive.
// Run: build/bench/param_apply_bench [values per drive = 200] [drives = 10] [rounds = 5]
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "adapters/core/clock.h"
#include "adapters/linmot/linudp/factory.h"
#include "server/core/parameter_apply.h"
#include "sim/linmot/server.h"
#include "storage/db.h"
#include "storage/migrations.h"
#include "storage/parameter_set_repo.h"

namespace {

using namespace std::chrono_literals;
using Steady = std::chrono::steady_clock;
using drivegw::Drive;
using drivegw::ParameterRef;

// Writable simulator UPIDs (sim/linmot/parameters.cpp) that no motion state depends on while the
// drive is disabled: currents, home offsets, lag limits, predefined VAI values, quick-stop,
// command-table variables, the D-32 project UPIDs.
constexpr uint16_t kUpids[] = {0x13A6, 0x13BA, 0x13C7, 0x13CA, 0x1473, 0x1475, 0x14BE,
                               0x14BF, 0x14C0, 0x14C1, 0x1721, 0x1E72, 0x1E73, 0xF000,
                               0xF001, 0xF002, 0xF004, 0xF006, 0xF007, 0xF008};
constexpr int kUpidCount = sizeof(kUpids) / sizeof(kUpids[0]);

std::string UpidName(uint16_t upid) {
  char buf[8];
  std::snprintf(buf, sizeof buf, "0x%04X", upid);
  return buf;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double Ms(Steady::duration d) { return std::chrono::duration<double, std::milli>(d).count(); }

[[noreturn]] void Die(const std::string& what) {
  std::fprintf(stderr, "param_apply_bench: %s\n", what.c_str());
  std::exit(1);
}

}  // namespace

int main(int argc, char** argv) {
  const int values = argc > 1 ? std::max(1, std::atoi(argv[1])) : 200;
  const int drive_count = argc > 2 ? std::max(1, std::atoi(argv[2])) : 10;
  const int rounds = argc > 3 ? std::max(1, std::atoi(argv[3])) : 5;
  const auto& clock = drivegw::SteadyClock::Instance();

  // ---- simulated drives and the gateway's drive objects -------------------------------------
  std::vector<std::unique_ptr<drivegw::sim::linmot::LinMotServer>> sims;
  std::vector<std::unique_ptr<Drive>> drives;
  for (int i = 0; i < drive_count; ++i) {
    drivegw::sim::linmot::SimOptions o;
    o.bind = drivegw::transport::Endpoint{drivegw::transport::Endpoint::kLoopback, 0};
    o.master_port = 0;  // answer the gateway's ephemeral port
    auto sim = drivegw::sim::linmot::LinMotServer::Start(o, clock);
    if (!sim.ok()) Die(std::string(sim.status().message()));
    drivegw::DriveConfig c;
    c.name = "x" + std::to_string(i + 1);
    c.family = "linmot";
    c.axis.min_mm = 0;
    c.axis.max_mm = 150;
    c.axis.max_velocity_mm_s = 1000;
    c.axis.max_acceleration_mm_s2 = 20000;
    drivegw::LinUdpConfig l;
    l.host = "127.0.0.1";
    l.port = (*sim)->port();
    l.bind_host = "127.0.0.1";
    l.master_port = 0;
    l.cycle = 1ms;  // the shortest cycle the factory accepts
    l.reply_timeout = 30ms;
    c.linudp = l;
    auto d = drivegw::linmot::linudp::CreateLinMotUdpDrive(c, clock);
    if (!d.ok()) Die(std::string(d.status().message()));
    if (auto s = (*d)->Activate(); !s.ok()) Die(std::string(s.message()));
    sims.push_back(*std::move(sim));
    drives.push_back(*std::move(d));
  }
  for (auto& d : drives) {
    const auto deadline = Steady::now() + 5s;
    auto s = d->GetStatus();
    while (s.state == drivegw::DriveState::kOffline && Steady::now() < deadline) {
      s = d->WaitForStatus(s.sequence, deadline);
    }
    if (s.state == drivegw::DriveState::kOffline) Die(d->config().name + " stays OFFLINE");
  }

  // ---- the set: start values of drive 1 (every simulated drive starts alike) ----------------
  std::vector<int64_t> start(kUpidCount);
  for (int u = 0; u < kUpidCount; ++u) {
    auto v = drives[0]->ReadParameter({kUpids[u], false});
    if (!v.ok()) Die(std::string(v.status().message()));
    start[u] = *v;
  }
  drivegw::storage::ParameterSet set;
  set.name = "bench";
  set.family = "linmot";
  set.version = 1;
  for (int i = 0; i < values; ++i) {
    const int u = i % kUpidCount;
    set.values.push_back({UpidName(kUpids[u]), kUpids[u], start[u] + i / kUpidCount + 1});
  }

  // Back to the start values (not timed) so that the next apply finds every value different.
  auto reset = [&] {
    for (auto& d : drives) {
      for (int u = 0; u < kUpidCount; ++u) {
        if (auto s = d->WriteParameter({kUpids[u], false}, start[u]); !s.ok()) {
          Die(std::string(s.message()));
        }
      }
    }
  };

  std::string dir = (std::filesystem::temp_directory_path() / "dgw_apply_bench_XXXXXX").string();
  if (mkdtemp(dir.data()) == nullptr) Die("mkdtemp " + dir);
  auto db = drivegw::storage::Db::Open(dir + "/gw.db");
  if (!db.ok()) Die(std::string(db.status().message()));
  if (auto s = drivegw::storage::Migrate(*db); !s.ok()) Die(std::string(s.message()));
  drivegw::storage::ParameterSetRepo repo(*db);
  drivegw::CatalogueList catalogues = {drivegw::linmot::linudp::LinMotParameterCatalogue()};
  drivegw::server::ParameterApplier applier(repo, catalogues);
  drivegw::server::ApplyRequest request;
  request.set = set;
  for (auto& d : drives) request.drives.push_back(d.get());
  request.principal = "bench";

  // Baseline and apply alternate round by round (the machine is shared: medians of each).
  std::vector<double> reads, writes, applies, stores;
  size_t written = 0;
  for (int round = 0; round < rounds; ++round) {
    // ---- baseline: bare Read + Write per value, through the same drives ---------------------
    Steady::duration read_sum{}, write_sum{};
    for (auto& d : drives) {
      for (const auto& v : set.values) {
        const ParameterRef ref{v.id, false};
        auto t0 = Steady::now();
        auto r = d->ReadParameter(ref);
        auto t1 = Steady::now();
        auto w = d->WriteParameter(ref, v.value);
        auto t2 = Steady::now();
        if (!r.ok()) Die(std::string(r.status().message()));
        if (!w.ok()) Die(std::string(w.message()));
        read_sum += t1 - t0;
        write_sum += t2 - t1;
      }
    }
    reads.push_back(Ms(read_sum));
    writes.push_back(Ms(write_sum));
    reset();

    // ---- the apply ---------------------------------------------------------------------------
    auto t0 = Steady::now();
    auto op = applier.Run(request);
    applies.push_back(Ms(Steady::now() - t0));
    if (!op.ok()) Die(std::string(op.status().message()));
    if (op->state != "SUCCEEDED") {
      Die("apply " + op->state + ": " + op->drives.back().failed_parameter + " " +
          op->drives.back().error);
    }
    written = 0;
    for (const auto& r : op->drives) written += r.written.size();
    // What storing the operation costs: the apply stores it once per drive (progress and the
    // final state); time as many updates of the final operation.
    auto s0 = Steady::now();
    for (int i = 0; i < drive_count; ++i) {
      if (auto s = repo.UpdateOperation(*op); !s.ok()) Die(std::string(s.message()));
    }
    stores.push_back(Ms(Steady::now() - s0));
    reset();
  }

  for (auto& d : drives) d->Deactivate();
  std::filesystem::remove_all(dir);

  const double n = static_cast<double>(values) * drive_count;
  const double read = Median(reads), write = Median(writes), apply = Median(applies),
               store = Median(stores);
  const double rw = Median([&] {
    std::vector<double> v;
    for (size_t i = 0; i < reads.size(); ++i) v.push_back(reads[i] + writes[i]);
    return v;
  }());
  const double mean_read = read / n;
  // The fewest round trips a verified apply needs: one pre-image read per UPID, then write and
  // read back per value.
  const int unique = std::min(values, kUpidCount);
  const double verified = write + read + mean_read * unique * drive_count;
  std::printf(
      "param_apply_bench: LinMot LinUDP sim, %d drives x %d values (%d distinct UPIDs), "
      "median of %d rounds\n",
      drive_count, values, unique, rounds);
  std::printf("  bare round trips: read %.3f ms, write %.3f ms per call (mean)\n", mean_read,
              write / n);
  std::printf("  baseline sum(Read+Write)          %9.1f ms\n", rw);
  std::printf("  minimum verified (pre+W+readback) %9.1f ms\n", verified);
  std::printf("  apply (ParameterApplier::Run)     %9.1f ms  (%zu values written and verified)\n",
              apply, written);
  std::printf(
      "  storing the operation             %9.1f ms  (%d updates timed apart, %.2f ms each)\n",
      store, drive_count, store / drive_count);
  std::printf("  ratio apply / baseline(R+W)       %9.2f\n", apply / rw);
  std::printf("  ratio apply / minimum verified    %9.2f\n", apply / verified);
  std::printf("  ratio (apply - store) / minimum   %9.2f\n", (apply - store) / verified);
  return 0;
}
