// Metrics registry: counters, gauges and fixed-bucket histograms with labels, rendered in the
// Prometheus text exposition format 0.0.4 (docs/decisions/021-metrics.md). Looking a series up
// takes the registry lock once; updating it is a relaxed atomic, so hot paths keep the reference.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace drivegw::ops {

// Label name -> value; kept sorted so one set of labels is one series whatever the call order.
using Labels = std::map<std::string, std::string>;

enum class MetricType { kCounter, kGauge, kHistogram };

class Counter {
 public:
  void Inc(double by = 1) noexcept;
  double value() const noexcept { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0};
};

class Gauge {
 public:
  void Set(double v) noexcept { value_.store(v, std::memory_order_relaxed); }
  void Add(double by) noexcept;
  double value() const noexcept { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0};
};

class Histogram {
 public:
  // `bounds`: upper bounds, strictly increasing, without +Inf (added at rendering).
  explicit Histogram(std::vector<double> bounds);
  void Observe(double v) noexcept;

  struct Snapshot {
    std::vector<double> bounds;
    std::vector<uint64_t> cumulative;  // per bound, then +Inf (= count)
    double sum = 0;
    uint64_t count = 0;
  };
  Snapshot snapshot() const;

 private:
  const std::vector<double> bounds_;
  std::unique_ptr<std::atomic<uint64_t>[]> buckets_;  // per bound, then +Inf (not cumulative)
  std::atomic<double> sum_{0};
  std::atomic<uint64_t> count_{0};
};

// Buckets for round trips and call latencies, seconds: 100 µs .. 10 s.
const std::vector<double>& LatencyBuckets();

// One sample a collector reports at scrape time (counters or gauges kept elsewhere, e.g. a
// session's exchange counters).
struct CollectedSample {
  std::string name;
  std::string help;
  MetricType type = MetricType::kGauge;
  Labels labels;
  double value = 0;
};
using Collector = std::function<void(std::vector<CollectedSample>& out)>;

class Registry {
 public:
  Registry() = default;
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  // The series of `name` with `labels`, created on first use. References stay valid for the
  // registry's life. A name keeps the type (and buckets) it was first registered with; a later
  // request with another type is a programming error and gets a detached series (not rendered).
  Counter& GetCounter(const std::string& name, const std::string& help, const Labels& labels = {});
  Gauge& GetGauge(const std::string& name, const std::string& help, const Labels& labels = {});
  Histogram& GetHistogram(const std::string& name, const std::string& help,
                          const std::vector<double>& bounds, const Labels& labels = {});

  // Called at every Render; returns an id for RemoveCollector.
  int AddCollector(Collector collector);
  void RemoveCollector(int id);

  // Text format 0.0.4: families sorted by name, one HELP and TYPE line each, series sorted by
  // labels; histograms as _bucket{le=...} (cumulative, +Inf last), _sum and _count.
  std::string Render() const;

 private:
  struct Family {
    std::string help;
    MetricType type = MetricType::kCounter;
    std::vector<double> bounds;
    std::map<Labels, std::unique_ptr<Counter>> counters;
    std::map<Labels, std::unique_ptr<Gauge>> gauges;
    std::map<Labels, std::unique_ptr<Histogram>> histograms;
  };
  Family* FamilyLocked(const std::string& name, const std::string& help, MetricType type,
                       const std::vector<double>& bounds);

  mutable std::mutex mu_;
  std::map<std::string, Family> families_;
  std::map<int, Collector> collectors_;
  int next_collector_ = 1;
  // Series of a mistyped request: kept alive, never rendered.
  std::vector<std::unique_ptr<Counter>> stray_counters_;
  std::vector<std::unique_ptr<Gauge>> stray_gauges_;
  std::vector<std::unique_ptr<Histogram>> stray_histograms_;
};

// The process-wide registry the gateway serves at GET /metrics.
Registry& DefaultRegistry();

// Text format helpers (exposed for tests): HELP text escapes \ and newline; label values also ".
std::string EscapeHelp(std::string_view text);
std::string EscapeLabelValue(std::string_view value);
// A sample value: shortest round-trip form, "+Inf", "-Inf", "NaN".
std::string FormatValue(double v);

// Audit trail write latency (WriteAudit, server/core/audit.cpp): one observation per append.
void ObserveAuditWrite(double seconds) noexcept;

// Cycle lateness of a cyclic set-point stream (server/core/cyclic_stream.cpp, at its end): set
// points that missed their cycle, cycles without a fresh one, cycles that carried one.
void ObserveCyclicStream(const std::string& drive, const std::string& family, uint64_t late,
                         uint64_t missing, uint64_t sent);

}  // namespace drivegw::ops
