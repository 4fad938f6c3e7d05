// Metrics registry and the Prometheus text exposition format 0.0.4 (decision 021).
#include "server/ops/metrics.h"

#include <algorithm>
#include <charconv>
#include <cmath>

namespace drivegw::ops {
namespace {

void AtomicAdd(std::atomic<double>& a, double by) noexcept {
  double cur = a.load(std::memory_order_relaxed);
  while (!a.compare_exchange_weak(cur, cur + by, std::memory_order_relaxed)) {
  }
}

const char* TypeName(MetricType t) {
  switch (t) {
    case MetricType::kCounter:
      return "counter";
    case MetricType::kGauge:
      return "gauge";
    case MetricType::kHistogram:
      return "histogram";
  }
  return "untyped";
}

// `{a="x",b="y"}`, with `extra` (le) last; "" for no labels at all.
std::string LabelText(const Labels& labels, const char* extra_name = nullptr,
                      const std::string& extra_value = {}) {
  if (labels.empty() && extra_name == nullptr) return "";
  std::string out = "{";
  bool first = true;
  for (const auto& [k, v] : labels) {
    if (!first) out += ',';
    first = false;
    out += k;
    out += "=\"";
    out += EscapeLabelValue(v);
    out += '"';
  }
  if (extra_name != nullptr) {
    if (!first) out += ',';
    out += extra_name;
    out += "=\"";
    out += extra_value;
    out += '"';
  }
  out += '}';
  return out;
}

void Line(std::string& out, const std::string& name, const std::string& labels, double v) {
  out += name;
  out += labels;
  out += ' ';
  out += FormatValue(v);
  out += '\n';
}

void Header(std::string& out, const std::string& name, const std::string& help, MetricType t) {
  out += "# HELP ";
  out += name;
  out += ' ';
  out += EscapeHelp(help);
  out += "\n# TYPE ";
  out += name;
  out += ' ';
  out += TypeName(t);
  out += '\n';
}

}  // namespace

void Counter::Inc(double by) noexcept {
  if (by > 0) AtomicAdd(value_, by);  // a counter never goes down
}

void Gauge::Add(double by) noexcept { AtomicAdd(value_, by); }

Histogram::Histogram(std::vector<double> bounds)
    : bounds_(std::move(bounds)),
      buckets_(std::make_unique<std::atomic<uint64_t>[]>(bounds_.size() + 1)) {}

void Histogram::Observe(double v) noexcept {
  const auto it = std::lower_bound(bounds_.begin(), bounds_.end(), v);  // le: v <= bound
  buckets_[static_cast<size_t>(it - bounds_.begin())].fetch_add(1, std::memory_order_relaxed);
  AtomicAdd(sum_, v);
  count_.fetch_add(1, std::memory_order_relaxed);
}

Histogram::Snapshot Histogram::snapshot() const {
  Snapshot s;
  s.bounds = bounds_;
  uint64_t running = 0;
  for (size_t i = 0; i <= bounds_.size(); ++i) {
    running += buckets_[i].load(std::memory_order_relaxed);
    s.cumulative.push_back(running);
  }
  // A scrape racing an Observe may see a bucket before the count: the +Inf bucket is the count,
  // so the two never disagree in one exposition.
  s.count = running;
  s.sum = sum_.load(std::memory_order_relaxed);
  return s;
}

const std::vector<double>& LatencyBuckets() {
  static const std::vector<double> kBuckets = {0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005,
                                               0.01,   0.025,   0.05,   0.1,   0.25,   0.5,
                                               1,      2.5,     5,      10};
  return kBuckets;
}

Registry::Family* Registry::FamilyLocked(const std::string& name, const std::string& help,
                                         MetricType type, const std::vector<double>& bounds) {
  auto [it, inserted] = families_.try_emplace(name);
  if (inserted) {
    it->second.help = help;
    it->second.type = type;
    it->second.bounds = bounds;
  }
  if (it->second.type != type) return nullptr;
  return &it->second;
}

Counter& Registry::GetCounter(const std::string& name, const std::string& help,
                              const Labels& labels) {
  std::lock_guard lock(mu_);
  Family* f = FamilyLocked(name, help, MetricType::kCounter, {});
  if (f == nullptr) return *stray_counters_.emplace_back(std::make_unique<Counter>());
  auto& slot = f->counters[labels];
  if (!slot) slot = std::make_unique<Counter>();
  return *slot;
}

Gauge& Registry::GetGauge(const std::string& name, const std::string& help, const Labels& labels) {
  std::lock_guard lock(mu_);
  Family* f = FamilyLocked(name, help, MetricType::kGauge, {});
  if (f == nullptr) return *stray_gauges_.emplace_back(std::make_unique<Gauge>());
  auto& slot = f->gauges[labels];
  if (!slot) slot = std::make_unique<Gauge>();
  return *slot;
}

Histogram& Registry::GetHistogram(const std::string& name, const std::string& help,
                                  const std::vector<double>& bounds, const Labels& labels) {
  std::lock_guard lock(mu_);
  Family* f = FamilyLocked(name, help, MetricType::kHistogram, bounds);
  if (f == nullptr) {
    return *stray_histograms_.emplace_back(std::make_unique<Histogram>(bounds));
  }
  auto& slot = f->histograms[labels];
  if (!slot) slot = std::make_unique<Histogram>(f->bounds);
  return *slot;
}

int Registry::AddCollector(Collector collector) {
  std::lock_guard lock(mu_);
  const int id = next_collector_++;
  collectors_.emplace(id, std::move(collector));
  return id;
}

void Registry::RemoveCollector(int id) {
  std::lock_guard lock(mu_);
  collectors_.erase(id);
}

std::string Registry::Render() const {
  // Collected samples are grouped like registered ones: one family per name.
  struct CollectedFamily {
    std::string help;
    MetricType type = MetricType::kGauge;
    std::map<Labels, double> series;
  };
  std::vector<Collector> collectors;
  {
    std::lock_guard lock(mu_);
    for (const auto& [id, c] : collectors_) collectors.push_back(c);
  }
  std::vector<CollectedSample> samples;
  for (const Collector& c : collectors) c(samples);  // outside the lock: they may take their own
  std::map<std::string, CollectedFamily> collected;
  for (CollectedSample& s : samples) {
    CollectedFamily& f = collected[s.name];
    if (f.series.empty()) {
      f.help = s.help;
      f.type = s.type;
    }
    f.series[s.labels] += s.value;  // one series reported twice (shared sessions) adds up
  }

  std::string out;
  std::lock_guard lock(mu_);
  for (const auto& [name, f] : families_) {
    if (collected.count(name) != 0) continue;  // a name belongs to one source; collected wins
    if (f.counters.empty() && f.gauges.empty() && f.histograms.empty()) continue;
    Header(out, name, f.help, f.type);
    for (const auto& [labels, c] : f.counters) Line(out, name, LabelText(labels), c->value());
    for (const auto& [labels, g] : f.gauges) Line(out, name, LabelText(labels), g->value());
    for (const auto& [labels, h] : f.histograms) {
      const Histogram::Snapshot s = h->snapshot();
      for (size_t i = 0; i < s.cumulative.size(); ++i) {
        const std::string le = i < s.bounds.size() ? FormatValue(s.bounds[i]) : "+Inf";
        Line(out, name + "_bucket", LabelText(labels, "le", le),
             static_cast<double>(s.cumulative[i]));
      }
      Line(out, name + "_sum", LabelText(labels), s.sum);
      Line(out, name + "_count", LabelText(labels), static_cast<double>(s.count));
    }
  }
  for (const auto& [name, f] : collected) {
    Header(out, name, f.help, f.type);
    for (const auto& [labels, v] : f.series) Line(out, name, LabelText(labels), v);
  }
  return out;
}

Registry& DefaultRegistry() {
  static Registry* registry = new Registry();  // never destroyed: metrics outlive every thread
  return *registry;
}

std::string EscapeHelp(std::string_view text) {
  std::string out;
  for (char c : text) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

std::string EscapeLabelValue(std::string_view value) {
  std::string out;
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '"') {
      out += "\\\"";
    } else {
      out += c;
    }
  }
  return out;
}

std::string FormatValue(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

void ObserveAuditWrite(double seconds) noexcept {
  static Histogram& h = DefaultRegistry().GetHistogram(
      "drivegw_audit_write_seconds", "Time to append one audit trail entry (SQLite, hash chain).",
      LatencyBuckets());
  h.Observe(seconds);
}

void ObserveCyclicStream(const std::string& drive, const std::string& family, uint64_t late,
                         uint64_t missing, uint64_t sent) {
  Registry& r = DefaultRegistry();
  const Labels l = {{"drive", drive}, {"family", family}};
  r.GetCounter("drivegw_cyclic_setpoints_late_total",
               "Cyclic set points that arrived after their cycle had gone (dropped).", l)
      .Inc(static_cast<double>(late));
  r.GetCounter("drivegw_cyclic_cycles_missing_total",
               "Cycles of a cyclic stream without a fresh set point (the drive extrapolated).", l)
      .Inc(static_cast<double>(missing));
  r.GetCounter("drivegw_cyclic_cycles_sent_total",
               "Cycles of a cyclic stream that carried a fresh set point.", l)
      .Inc(static_cast<double>(sent));
}

}  // namespace drivegw::ops
