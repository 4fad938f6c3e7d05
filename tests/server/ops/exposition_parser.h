// Test support: a small parser of the Prometheus text exposition format 0.0.4 — enough to check
// what drivegw serves at /metrics (names, labels with escapes, HELP/TYPE, histogram series).
#pragma once

#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace drivegw::ops::test_support {

struct ParsedSample {
  std::string name;
  std::map<std::string, std::string> labels;
  double value = 0;
};

struct ParsedExposition {
  std::map<std::string, std::string> help;  // family -> text (unescaped)
  std::map<std::string, std::string> type;  // family -> counter/gauge/histogram/...
  std::vector<ParsedSample> samples;
  std::vector<std::string> errors;  // lines that are not valid 0.0.4

  // Samples of `name` whose labels include every pair of `labels`.
  std::vector<ParsedSample> Find(const std::string& name,
                                 const std::map<std::string, std::string>& labels = {}) const {
    std::vector<ParsedSample> out;
    for (const ParsedSample& s : samples) {
      if (s.name != name) continue;
      bool match = true;
      for (const auto& [k, v] : labels) {
        auto it = s.labels.find(k);
        if (it == s.labels.end() || it->second != v) match = false;
      }
      if (match) out.push_back(s);
    }
    return out;
  }
  double Sum(const std::string& name, const std::map<std::string, std::string>& labels = {}) const {
    double sum = 0;
    for (const ParsedSample& s : Find(name, labels)) sum += s.value;
    return sum;
  }
};

inline bool ValidMetricName(const std::string& n) {
  static const std::regex re("[a-zA-Z_:][a-zA-Z0-9_:]*");
  return std::regex_match(n, re);
}

inline std::optional<double> ParseValue(const std::string& v) {
  if (v == "+Inf") return HUGE_VAL;
  if (v == "-Inf") return -HUGE_VAL;
  if (v == "NaN") return std::nan("");
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size()) return std::nullopt;
  return d;
}

// Label block after the name: {k="v",...} with \\, \" and \n escapes in values.
inline bool ParseLabels(const std::string& line, size_t& pos,
                        std::map<std::string, std::string>& out) {
  if (pos >= line.size() || line[pos] != '{') return true;
  ++pos;
  while (pos < line.size() && line[pos] != '}') {
    size_t eq = line.find('=', pos);
    if (eq == std::string::npos) return false;
    const std::string key = line.substr(pos, eq - pos);
    if (!std::regex_match(key, std::regex("[a-zA-Z_][a-zA-Z0-9_]*"))) return false;
    pos = eq + 1;
    if (pos >= line.size() || line[pos] != '"') return false;
    ++pos;
    std::string value;
    while (pos < line.size() && line[pos] != '"') {
      if (line[pos] == '\\') {
        if (pos + 1 >= line.size()) return false;
        const char e = line[pos + 1];
        if (e == 'n') {
          value += '\n';
        } else if (e == '\\' || e == '"') {
          value += e;
        } else {
          return false;
        }
        pos += 2;
      } else {
        value += line[pos++];
      }
    }
    if (pos >= line.size()) return false;
    ++pos;                                  // closing quote
    if (out.count(key) != 0) return false;  // duplicate label
    out[key] = value;
    if (pos < line.size() && line[pos] == ',') ++pos;
  }
  if (pos >= line.size()) return false;
  ++pos;  // '}'
  return true;
}

inline ParsedExposition ParseExposition(const std::string& text) {
  ParsedExposition e;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line.rfind("# HELP ", 0) == 0 || line.rfind("# TYPE ", 0) == 0) {
      const bool help = line[2] == 'H';
      const std::string rest = line.substr(7);
      const size_t sp = rest.find(' ');
      const std::string name = rest.substr(0, sp);
      const std::string arg = sp == std::string::npos ? "" : rest.substr(sp + 1);
      if (!ValidMetricName(name)) e.errors.push_back("bad family name: " + line);
      auto& map = help ? e.help : e.type;
      if (map.count(name) != 0) e.errors.push_back("second HELP/TYPE: " + line);
      if (help) {
        std::string unescaped;
        for (size_t i = 0; i < arg.size(); ++i) {
          if (arg[i] == '\\' && i + 1 < arg.size()) {
            unescaped += arg[i + 1] == 'n' ? '\n' : arg[i + 1];
            ++i;
          } else {
            unescaped += arg[i];
          }
        }
        map[name] = unescaped;
      } else {
        static const std::regex types("counter|gauge|histogram|summary|untyped");
        if (!std::regex_match(arg, types)) e.errors.push_back("bad TYPE: " + line);
        map[name] = arg;
      }
      continue;
    }
    if (line[0] == '#') continue;  // comment
    ParsedSample s;
    size_t pos = 0;
    while (pos < line.size() && line[pos] != '{' && line[pos] != ' ') ++pos;
    s.name = line.substr(0, pos);
    if (!ValidMetricName(s.name) || !ParseLabels(line, pos, s.labels) || pos >= line.size() ||
        line[pos] != ' ') {
      e.errors.push_back("bad sample: " + line);
      continue;
    }
    std::string value = line.substr(pos + 1);
    if (auto ts = value.find(' '); ts != std::string::npos) value = value.substr(0, ts);
    auto v = ParseValue(value);
    if (!v) {
      e.errors.push_back("bad value: " + line);
      continue;
    }
    s.value = *v;
    e.samples.push_back(std::move(s));
  }
  return e;
}

// The family a sample belongs to: histogram samples drop _bucket/_sum/_count.
inline std::string FamilyOf(const ParsedExposition& e, const std::string& sample) {
  for (const char* suffix : {"_bucket", "_sum", "_count"}) {
    const std::string sfx = suffix;
    if (sample.size() > sfx.size() &&
        sample.compare(sample.size() - sfx.size(), sfx.size(), sfx) == 0) {
      const std::string base = sample.substr(0, sample.size() - sfx.size());
      auto it = e.type.find(base);
      if (it != e.type.end() && it->second == "histogram") return base;
    }
  }
  return sample;
}

// Every histogram series: buckets sorted by le are non-decreasing, the last is le="+Inf" and
// equals _count. Returns the problems found ("" when none).
inline std::string CheckHistograms(const ParsedExposition& e) {
  std::string problems;
  for (const auto& [family, type] : e.type) {
    if (type != "histogram") continue;
    std::map<std::map<std::string, std::string>, std::vector<std::pair<double, double>>> series;
    for (const ParsedSample& s : e.samples) {
      if (s.name != family + "_bucket") continue;
      auto labels = s.labels;
      auto le = labels.find("le");
      if (le == labels.end()) {
        problems += family + ": bucket without le; ";
        continue;
      }
      const auto bound = ParseValue(le->second);
      labels.erase(le);
      series[labels].push_back({bound.value_or(std::nan("")), s.value});
    }
    for (auto& [labels, buckets] : series) {
      std::sort(buckets.begin(), buckets.end());
      for (size_t i = 1; i < buckets.size(); ++i) {
        if (buckets[i].second < buckets[i - 1].second) problems += family + ": buckets decrease; ";
      }
      if (buckets.empty() || !std::isinf(buckets.back().first)) {
        problems += family + ": no +Inf bucket; ";
        continue;
      }
      double count = -1;
      for (const ParsedSample& s : e.samples) {
        if (s.name == family + "_count" && s.labels == labels) count = s.value;
      }
      if (count != buckets.back().second) problems += family + ": +Inf bucket != _count; ";
    }
  }
  return problems;
}

}  // namespace drivegw::ops::test_support
