#include "server/metrics.h"

#include <cstdio>
#include <sstream>

namespace server {
namespace {

struct Description {
  const char* type;
  const char* help;
};

// Families fleetd exports; anything else renders as an untyped gauge.
const std::map<std::string, Description>& Descriptions() {
  static const std::map<std::string, Description> kDescriptions = {
      {"fleetd_rpc_total", {"counter", "RPCs handled, by method and status code"}},
      {"fleetd_rpc_latency_seconds", {"histogram", "RPC latency, by method"}},
      {"fleetd_ingest_runs_total",
       {"counter", "Uploaded runs, by outcome (stored, already_present, rejected)"}},
      {"fleetd_ingest_bytes_total", {"counter", "Bytes received by UploadRun"}},
      {"fleetd_ingest_events_total", {"counter", "Events stored by UploadRun"}},
      {"fleetd_job_queue_depth", {"gauge", "Jobs waiting, by state"}},
      {"fleetd_jobs_total", {"counter", "Jobs finished by this process's workers, by kind and outcome"}},
      {"fleetd_analysis_seconds", {"histogram", "Wall time of one run's analysis"}},
      {"fleetd_job_progress_ratio", {"gauge", "Progress of running reprocessing jobs (0..1)"}},
      {"fleetd_workers", {"gauge", "Analysis worker threads in this process"}},
      {"fleetd_upload_streams_in_flight",
       {"gauge", "Upload streams open now (bounded by --max-upload-streams)"}},
      {"fleetd_upload_bytes_in_flight",
       {"gauge", "Bytes buffered by uploads in flight (--max-upload-bytes-in-flight)"}},
  };
  return kDescriptions;
}

std::string Number(double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

std::string Series(const std::string& name, const std::string& labels) {
  return labels.empty() ? name : name + "{" + labels + "}";
}

}  // namespace

std::string LabelValue(const std::string& value) {
  std::string out;
  for (char c : value) {
    if (c == '\\' || c == '"') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

Metrics::Metrics() : buckets_{0.001, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30, 60} {}

Metrics::Family& Metrics::FamilyLocked(const std::string& name) {
  auto [it, inserted] = families_.try_emplace(name);
  if (inserted) {
    const auto& descriptions = Descriptions();
    auto d = descriptions.find(name);
    it->second.type = d == descriptions.end() ? "gauge" : d->second.type;
    it->second.help = d == descriptions.end() ? name : d->second.help;
  }
  return it->second;
}

void Metrics::Increment(const std::string& name, const std::string& labels, double value) {
  std::lock_guard lock(mutex_);
  FamilyLocked(name).values[labels] += value;
}

void Metrics::SetGauge(const std::string& name, const std::string& labels, double value) {
  std::lock_guard lock(mutex_);
  FamilyLocked(name).values[labels] = value;
}

void Metrics::Observe(const std::string& name, const std::string& labels, double seconds) {
  std::lock_guard lock(mutex_);
  Histogram& histogram = FamilyLocked(name).histograms[labels];
  if (histogram.counts.empty()) histogram.counts.assign(buckets_.size(), 0.0);
  for (std::size_t i = 0; i < buckets_.size(); ++i) {
    if (seconds <= buckets_[i]) {
      histogram.counts[i] += 1;
      break;
    }
  }
  histogram.sum += seconds;
  histogram.count += 1;
}

void Metrics::AddCollector(std::function<void(Metrics&)> collector) {
  std::lock_guard lock(mutex_);
  collectors_.push_back(std::move(collector));
}

double Metrics::Value(const std::string& name, const std::string& labels) {
  std::lock_guard lock(mutex_);
  auto family = families_.find(name);
  if (family == families_.end()) return 0.0;
  auto value = family->second.values.find(labels);
  return value == family->second.values.end() ? 0.0 : value->second;
}

std::string Metrics::Render() {
  std::lock_guard render_lock(render_mutex_);
  std::vector<std::function<void(Metrics&)>> collectors;
  {
    std::lock_guard lock(mutex_);
    collectors = collectors_;
  }
  for (auto& collector : collectors) collector(*this);

  std::lock_guard lock(mutex_);
  std::ostringstream out;
  for (const auto& [name, family] : families_) {
    out << "# HELP " << name << " " << family.help << "\n# TYPE " << name << " " << family.type << "\n";
    for (const auto& [labels, value] : family.values)
      out << Series(name, labels) << " " << Number(value) << "\n";
    for (const auto& [labels, histogram] : family.histograms) {
      const std::string prefix = labels.empty() ? "" : labels + ",";
      double cumulative = 0.0;
      for (std::size_t i = 0; i < buckets_.size(); ++i) {
        cumulative += histogram.counts[i];
        out << name << "_bucket{" << prefix << "le=\"" << Number(buckets_[i]) << "\"} " << Number(cumulative)
            << "\n";
      }
      out << name << "_bucket{" << prefix << "le=\"+Inf\"} " << Number(histogram.count) << "\n";
      out << Series(name + "_sum", labels) << " " << Number(histogram.sum) << "\n";
      out << Series(name + "_count", labels) << " " << Number(histogram.count) << "\n";
    }
  }
  return out.str();
}

}  // namespace server
