// The metrics registry and its exposition (decision 021), read back by the test's own parser.
#include "server/ops/metrics.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <thread>

#include "server/ops/readiness.h"
#include "tests/server/ops/exposition_parser.h"

namespace drivegw::ops {
namespace {

using test_support::CheckHistograms;
using test_support::FamilyOf;
using test_support::ParseExposition;

TEST(MetricsRender_Counters_HelpTypeAndLabels, ParsesBack) {
  Registry r;
  r.GetCounter("dgw_test_requests_total", "Requests.", {{"drive", "x1"}, {"family", "linmot"}})
      .Inc();
  r.GetCounter("dgw_test_requests_total", "Requests.", {{"family", "linmot"}, {"drive", "x1"}})
      .Inc(2);  // same series whatever the label order
  r.GetCounter("dgw_test_requests_total", "Requests.", {{"drive", "x2"}, {"family", "linmot"}});
  r.GetGauge("dgw_test_online", "Online.").Set(1);
  const auto e = ParseExposition(r.Render());
  EXPECT_TRUE(e.errors.empty()) << e.errors.front();
  EXPECT_EQ(e.type.at("dgw_test_requests_total"), "counter");
  EXPECT_EQ(e.type.at("dgw_test_online"), "gauge");
  EXPECT_EQ(e.help.at("dgw_test_requests_total"), "Requests.");
  EXPECT_EQ(e.Sum("dgw_test_requests_total", {{"drive", "x1"}}), 3);
  EXPECT_EQ(e.Find("dgw_test_requests_total", {{"drive", "x2"}}).size(), 1u);
  EXPECT_EQ(e.Sum("dgw_test_online"), 1);
  // Every sample has a TYPE line before it.
  for (const auto& s : e.samples) EXPECT_EQ(e.type.count(FamilyOf(e, s.name)), 1u) << s.name;
}

TEST(MetricsRender_LabelValuesWithEscapes, RoundTrip) {
  Registry r;
  const std::string nasty = "a\"b\\c\nd";
  r.GetCounter("dgw_test_escaped_total", "Help with \\ and\nnewline.", {{"v", nasty}}).Inc();
  const std::string text = r.Render();
  EXPECT_NE(text.find(R"(v="a\"b\\c\nd")"), std::string::npos) << text;
  EXPECT_NE(text.find(R"(# HELP dgw_test_escaped_total Help with \\ and\nnewline.)"),
            std::string::npos)
      << text;
  const auto e = ParseExposition(text);
  ASSERT_TRUE(e.errors.empty()) << e.errors.front();
  ASSERT_EQ(e.Find("dgw_test_escaped_total").size(), 1u);
  EXPECT_EQ(e.Find("dgw_test_escaped_total")[0].labels.at("v"), nasty);
  EXPECT_EQ(e.help.at("dgw_test_escaped_total"), "Help with \\ and\nnewline.");
}

TEST(MetricsRender_Histogram_BucketsCumulativeInfEqualsCount, Monotonic) {
  Registry r;
  Histogram& h = r.GetHistogram("dgw_test_rtt_seconds", "RTT.", {0.001, 0.01, 0.1}, {{"d", "x"}});
  for (double v : {0.0005, 0.001, 0.002, 0.05, 0.5, 7.0}) h.Observe(v);
  const auto e = ParseExposition(r.Render());
  ASSERT_TRUE(e.errors.empty()) << e.errors.front();
  EXPECT_EQ(e.type.at("dgw_test_rtt_seconds"), "histogram");
  EXPECT_EQ(CheckHistograms(e), "");
  // le is inclusive: 0.001 lands in the first bucket.
  EXPECT_EQ(e.Sum("dgw_test_rtt_seconds_bucket", {{"le", "0.001"}}), 2);
  EXPECT_EQ(e.Sum("dgw_test_rtt_seconds_bucket", {{"le", "0.01"}}), 3);
  EXPECT_EQ(e.Sum("dgw_test_rtt_seconds_bucket", {{"le", "0.1"}}), 4);
  EXPECT_EQ(e.Sum("dgw_test_rtt_seconds_bucket", {{"le", "+Inf"}}), 6);
  EXPECT_EQ(e.Sum("dgw_test_rtt_seconds_count"), 6);
  EXPECT_NEAR(e.Sum("dgw_test_rtt_seconds_sum"), 7.5535, 1e-9);
}

TEST(MetricsRegistry_ConcurrentUpdates, NoneLost) {
  Registry r;
  Counter& c = r.GetCounter("dgw_test_concurrent_total", "C.");
  Histogram& h = r.GetHistogram("dgw_test_concurrent_seconds", "H.", LatencyBuckets());
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 10000; ++i) {
        c.Inc();
        h.Observe(0.002);
      }
    });
  }
  for (auto& t : threads) t.join();
  const auto e = ParseExposition(r.Render());
  EXPECT_EQ(e.Sum("dgw_test_concurrent_total"), 40000);
  EXPECT_EQ(e.Sum("dgw_test_concurrent_seconds_count"), 40000);
  EXPECT_EQ(CheckHistograms(e), "");
}

TEST(MetricsRegistry_Collector_ReportedAtScrapeAndRemoved, Works) {
  Registry r;
  int calls = 0;
  const int id = r.AddCollector([&](std::vector<CollectedSample>& out) {
    ++calls;
    out.push_back(
        {"dgw_test_collected_total", "Collected.", MetricType::kCounter, {{"drive", "x1"}}, 41});
    out.push_back({"dgw_test_collected_total",
                   "Collected.",
                   MetricType::kCounter,
                   {{"drive", "x1"}},
                   1});  // the same series twice adds up
  });
  auto e = ParseExposition(r.Render());
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(e.type.at("dgw_test_collected_total"), "counter");
  EXPECT_EQ(e.Sum("dgw_test_collected_total", {{"drive", "x1"}}), 42);
  r.RemoveCollector(id);
  e = ParseExposition(r.Render());
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(e.Find("dgw_test_collected_total").empty());
}

TEST(MetricsFormatValue_SpecialValues, PrometheusSpelling) {
  EXPECT_EQ(FormatValue(1), "1");
  EXPECT_EQ(FormatValue(0.25), "0.25");
  EXPECT_EQ(FormatValue(HUGE_VAL), "+Inf");
  EXPECT_EQ(FormatValue(-HUGE_VAL), "-Inf");
  EXPECT_EQ(FormatValue(std::nan("")), "NaN");
}

TEST(ObserveAuditWrite_DefaultRegistry, HistogramServed) {
  ObserveAuditWrite(0.003);
  const auto e = ParseExposition(DefaultRegistry().Render());
  EXPECT_GE(e.Sum("drivegw_audit_write_seconds_count"), 1);
  EXPECT_EQ(CheckHistograms(e), "");
}

TEST(ObserveCyclicStream_DefaultRegistry, LatenessCountersAddUp) {
  ObserveCyclicStream("s9", "stober", 2, 3, 40);
  ObserveCyclicStream("s9", "stober", 1, 0, 10);
  const auto e = ParseExposition(DefaultRegistry().Render());
  EXPECT_EQ(e.Sum("drivegw_cyclic_setpoints_late_total", {{"drive", "s9"}, {"family", "stober"}}),
            3);
  EXPECT_EQ(e.Sum("drivegw_cyclic_cycles_missing_total", {{"drive", "s9"}}), 3);
  EXPECT_EQ(e.Sum("drivegw_cyclic_cycles_sent_total", {{"drive", "s9"}}), 50);
}

TEST(Readiness_StorageThenDrives_NotReadyUntilAllTried, ThenNotReadyAtShutdown) {
  Readiness r;
  EXPECT_EQ(r.Check().message(), "storage not open");
  r.SetStorageOpen(true);
  r.ExpectDrives({"x1", "s1"});
  EXPECT_EQ(r.Check().message(), "drives not tried yet: x1, s1");
  r.MarkDriveTried("s1");
  EXPECT_EQ(r.Check().message(), "drives not tried yet: x1");
  r.MarkDriveTried("x1");
  EXPECT_TRUE(r.Check().ok());
  r.SetShuttingDown();
  EXPECT_EQ(r.Check().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(r.Check().message(), "shutting down");
}

}  // namespace
}  // namespace drivegw::ops
