// One line per measured target, for scripts/bench.sh (issue 10): besides its table for people,
// every benchmark prints its results as
//   @result {"id":"P1","metric":"move_ack_ratio_p50","value":1.76,"target":"<=1.3","unit":"ratio",
//            "baseline":"bare gRPC echo + bare UDP round trip","detail":{...}}
// scripts/bench.sh collects these lines into bench/results/latest.json and the table in
// docs/performance.md. `target` is the target as text ("<=1.3", ">=200", "<64"), empty
// for a number that only informs; `met` is computed here so the table never disagrees with it.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

namespace drivegw::bench {

struct Result {
  std::string id;        // P1 ... P7 (issue 10), or a bench's own id for extra numbers
  std::string metric;    // snake_case name of what was measured
  double value = 0;
  std::string unit;      // "ratio", "us", "per_s", "MB", "ms", "drives", "frames", ...
  std::string target;    // "<=1.3", ">=0.8", "<64", "=2", "" (informational)
  std::string baseline;  // what the value is compared with, measured in the same run
  nlohmann::json detail = nlohmann::json::object();  // raw numbers behind the value
};

// True when `value` meets `target` ("<=x", ">=x", "<x", ">x", "=x"); true for an empty target.
inline bool Meets(double value, std::string_view target) {
  if (target.empty()) return true;
  size_t op_len = (target.size() > 1 && target[1] == '=') ? 2 : 1;
  const std::string op(target.substr(0, op_len));
  const double limit = std::stod(std::string(target.substr(op_len)));
  if (op == "<=") return value <= limit;
  if (op == ">=") return value >= limit;
  if (op == "<") return value < limit;
  if (op == ">") return value > limit;
  return value == limit;  // "=": frame counts, exact by nature
}

// Prints the @result line on stdout (flushed: benchmarks may be killed by a timeout).
inline void Report(const Result& r) {
  nlohmann::json j = {{"id", r.id},         {"metric", r.metric}, {"value", r.value},
                      {"unit", r.unit},     {"target", r.target}, {"met", Meets(r.value, r.target)},
                      {"baseline", r.baseline}, {"detail", r.detail}};
  std::printf("@result %s\n", j.dump().c_str());
  std::fflush(stdout);
}

}  // namespace drivegw::bench
