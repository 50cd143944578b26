// Prometheus metrics kept by fleetd and rendered in the text exposition format (version 0.0.4) for
// GET /metrics. Small and hand-written: counters, gauges and fixed-bucket histograms, each series named
// by metric name plus a label string such as `method="UploadRun",code="OK"`.
//
// Thread safety: every method is safe from any thread (one mutex; updates are a few map look-ups).
#pragma once

#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace server {

class Metrics {
 public:
  Metrics();

  void Increment(const std::string& name, const std::string& labels = "", double value = 1.0);
  void SetGauge(const std::string& name, const std::string& labels, double value);
  /// Histogram observation in seconds (buckets 1 ms … 60 s).
  void Observe(const std::string& name, const std::string& labels, double seconds);
  /// Called on every Render() before the text is produced, e.g. to read the queue depth.
  void AddCollector(std::function<void(Metrics&)> collector);

  std::string Render();

  /// Value of a counter or gauge series (0 when absent); for tests and logs.
  double Value(const std::string& name, const std::string& labels = "");

 private:
  struct Histogram {
    std::vector<double> counts;  // per bucket, not cumulative
    double sum = 0.0;
    double count = 0.0;
  };
  struct Family {
    std::string type;  // "counter", "gauge", "histogram"
    std::string help;
    std::map<std::string, double> values;
    std::map<std::string, Histogram> histograms;
  };
  Family& FamilyLocked(const std::string& name);

  std::mutex mutex_;  // guards families_ and collectors_
  std::map<std::string, Family> families_;
  std::vector<std::function<void(Metrics&)>> collectors_;
  std::mutex render_mutex_;  // one Render() at a time (collectors call back into this object)
  const std::vector<double> buckets_;
};

/// Escapes a label value for the text format.
std::string LabelValue(const std::string& value);

}  // namespace server
