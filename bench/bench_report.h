// A Google Benchmark reporter that also pairs each "NAME/baseline" run with its "NAME/candidate" run and
// prints the ratio of their times, so every benchmark reports against a baseline measured in the same run.
#pragma once

#include <benchmark/benchmark.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

namespace bench {

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  RatioReporter(std::string baseline, std::string candidate)
      : baseline_(std::move(baseline)), candidate_(std::move(candidate)) {}

  void ReportRuns(const std::vector<Run>& runs) override {
    ConsoleReporter::ReportRuns(runs);
    for (const Run& run : runs) {
      // With --benchmark_repetitions the median stands for the benchmark; the single repetitions and the
      // other aggregates (mean, stddev, cv: the last reported) would otherwise overwrite it.
      const bool repeated = run.repetitions > 1;
      if (repeated && (run.run_type != Run::RT_Aggregate || run.aggregate_name != "median")) continue;
      const std::string name = run.run_name.function_name;
      const std::size_t slash = name.rfind('/');
      if (slash == std::string::npos) continue;
      Entry& entry = entries_[name.substr(0, slash)];
      const std::string variant = name.substr(slash + 1);
      const double seconds = run.GetAdjustedRealTime();
      times_[name] = seconds;
      const auto counter = run.counters.find("chi2");
      const double value = counter == run.counters.end() ? 0.0 : counter->second.value;
      if (variant == baseline_) entry.baseline = {seconds, value};
      if (variant == candidate_) entry.candidate = {seconds, value};
    }
  }

  /// One line per pair: ratio = baseline time / candidate time, and both runs' "chi2" counters if set.
  void PrintRatios(const char* title) const {
    std::printf("\n%-36s %12s %12s %10s %14s %14s\n", "benchmark", baseline_.c_str(), candidate_.c_str(),
                "ratio", (baseline_ + " chi2").c_str(), (candidate_ + " chi2").c_str());
    for (const auto& [name, entry] : entries_) {
      if (entry.baseline.time <= 0 || entry.candidate.time <= 0) continue;
      std::printf("%-36s %12.3f %12.3f %10.2f %14.6g %14.6g\n", name.c_str(), entry.baseline.time,
                  entry.candidate.time, entry.baseline.time / entry.candidate.time, entry.baseline.value,
                  entry.candidate.value);
    }
    std::printf("(%s; times in the benchmark's unit)\n", title);
  }

  /// Every run's time by benchmark name, in the benchmark's unit.
  const std::map<std::string, double>& Times() const { return times_; }

 private:
  struct Measurement {
    double time = 0.0;
    double value = 0.0;
  };
  struct Entry {
    Measurement baseline, candidate;
  };
  std::string baseline_, candidate_;
  std::map<std::string, Entry> entries_;
  std::map<std::string, double> times_;
};

/// How each variant's time grows from a small to a large problem: time(large/VARIANT) / time(small/VARIANT).
inline void PrintScaling(const std::map<std::string, double>& times, const std::string& small,
                         const std::string& large, const std::vector<std::string>& variants) {
  std::printf("\n%-14s %14s %14s %10s   (%s -> %s)\n", "variant", "small", "large", "growth", small.c_str(),
              large.c_str());
  for (const std::string& variant : variants) {
    const auto a = times.find(small + "/" + variant), b = times.find(large + "/" + variant);
    if (a == times.end() || b == times.end() || a->second <= 0) continue;
    std::printf("%-14s %14.3f %14.3f %10.2f\n", variant.c_str(), a->second, b->second, b->second / a->second);
  }
}

}  // namespace bench
