#include "server/metrics.h"

#include <prometheus/counter.h>
#include <prometheus/family.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <utility>

namespace sceneloc {
namespace {

using prometheus::ClientMetric;
using prometheus::MetricFamily;
using prometheus::MetricType;

// Seconds, 1 ms .. 10 s: a feature set takes ~20 ms, a JPEG ~50 ms, a queued burst seconds.
const prometheus::Histogram::BucketBoundaries& LatencyBuckets() {
  static const prometheus::Histogram::BucketBoundaries buckets = {
      0.001, 0.0025, 0.005, 0.01, 0.02, 0.035, 0.05, 0.075,
      0.1,   0.15,   0.25,  0.5,  1.0,  2.5,   5.0,  10.0};
  return buckets;
}

// The engine's stages as Timings holds them (proto/sceneloc.proto).
struct Stage {
  const char* name;
  double (v1::Timings::*ms)() const;
};
constexpr Stage kStages[] = {
    {"queue", &v1::Timings::queue_ms},
    {"decode", &v1::Timings::decode_ms},
    {"extract", &v1::Timings::extract_ms},
    {"place", &v1::Timings::place_ms},
    {"holistic", &v1::Timings::holistic_ms},
    {"descriptor", &v1::Timings::descriptor_ms},
    {"neighbourhood", &v1::Timings::neighbourhood_ms},
    {"likelihood", &v1::Timings::likelihood_ms},
    {"verify", &v1::Timings::verify_ms},
};

ClientMetric Value(double value, std::vector<ClientMetric::Label> labels = {}) {
  ClientMetric m;
  m.label = std::move(labels);
  m.gauge.value = value;
  m.counter.value = value;
  return m;
}

MetricFamily Family(std::string name, std::string help, MetricType type,
                    std::vector<ClientMetric> metrics) {
  return {std::move(name), std::move(help), type, std::move(metrics)};
}

// The families read at scrape time.
std::vector<MetricFamily> Held(const ServerGauges& g, const MapRegistry& maps) {
  std::vector<MetricFamily> out;
  const MetricType gauge = MetricType::Gauge;
  const MetricType counter = MetricType::Counter;
  out.push_back(Family("sceneloc_uptime_seconds", "Seconds since the server started", gauge,
                       {Value(g.uptime_s)}));
  out.push_back(Family("sceneloc_queue_depth", "Requests waiting for a worker", gauge,
                       {Value(static_cast<double>(g.queue_depth))}));
  out.push_back(Family("sceneloc_requests_in_flight", "Requests received and not yet answered",
                       gauge, {Value(static_cast<double>(g.in_flight))}));
  out.push_back(
      Family("sceneloc_workers", "Worker threads (server.threads)", gauge, {Value(g.workers)}));
  out.push_back(Family("sceneloc_workers_busy", "Worker threads running a request", gauge,
                       {Value(g.busy_workers)}));
  out.push_back(Family("sceneloc_sessions", "Live robot sessions", gauge,
                       {Value(static_cast<double>(g.sessions))}));
  out.push_back(Family("sceneloc_session_memory_bytes", "Memory of the live sessions", gauge,
                       {Value(static_cast<double>(g.session_bytes))}));
  out.push_back(Family("sceneloc_draining", "1 while the server shuts down", gauge,
                       {Value(g.draining ? 1 : 0)}));
  if (g.keeps_frames) {
    const KeepFramesCounts& k = g.kept;
    out.push_back(Family("sceneloc_kept_frames_bytes", "Bytes of the frames kept (keep_frames)",
                         gauge, {Value(static_cast<double>(k.bytes_used))}));
    out.push_back(Family("sceneloc_kept_frames_quota_bytes", "keep_frames.quota_bytes", gauge,
                         {Value(static_cast<double>(k.quota_bytes))}));
    out.push_back(Family("sceneloc_kept_frames_total", "Frames kept since start", counter,
                         {Value(static_cast<double>(k.kept))}));
    out.push_back(
        Family("sceneloc_kept_frames_dropped_total",
               "Frames of failing sessions not kept: quota full, memory full, or the disk refused",
               counter,
               {Value(static_cast<double>(k.dropped_quota), {{"reason", "quota"}}),
                Value(static_cast<double>(k.dropped_memory), {{"reason", "memory"}}),
                Value(static_cast<double>(k.write_failures), {{"reason", "write"}})}));
  }
  std::vector<ClientMetric> generation, locations, landmarks, bytes;
  const auto loaded = maps.List();
  for (const auto& map : loaded) {
    const std::vector<ClientMetric::Label> label = {{"map", map->name}};
    generation.push_back(Value(static_cast<double>(map->generation), label));
    locations.push_back(Value(map->map.num_places(), label));
    landmarks.push_back(Value(map->map.num_landmarks(), label));
    bytes.push_back(Value(static_cast<double>(map->map.MemoryBytes()), label));
  }
  out.push_back(Family("sceneloc_maps_loaded", "Maps serving", gauge,
                       {Value(static_cast<double>(loaded.size()))}));
  out.push_back(Family("sceneloc_map_generation",
                       "Load generation of each map serving (1 on its first load, +1 per reload)",
                       gauge, std::move(generation)));
  out.push_back(Family("sceneloc_map_locations", "Tour locations of each map serving", gauge,
                       std::move(locations)));
  out.push_back(Family("sceneloc_map_landmarks", "Landmarks of each map serving", gauge,
                       std::move(landmarks)));
  out.push_back(
      Family("sceneloc_map_memory_bytes", "Memory of each map serving", gauge, std::move(bytes)));
  out.push_back(Family("sceneloc_map_loads_total", "Successful map loads", counter,
                       {Value(static_cast<double>(maps.loads()))}));
  out.push_back(Family("sceneloc_map_load_failures_total",
                       "Failed map loads (the old map, if any, kept serving)", counter,
                       {Value(static_cast<double>(maps.load_failures()))}));
  out.push_back(Family("sceneloc_map_unloads_total", "Maps unloaded (their file removed)", counter,
                       {Value(static_cast<double>(maps.unloads()))}));
  return out;
}

}  // namespace

struct Metrics::Families {
  prometheus::Registry registry;
  prometheus::Family<prometheus::Counter>& requests =
      prometheus::BuildCounter()
          .Name("sceneloc_requests_total")
          .Help("Replies sent, by request kind, status and map")
          .Register(registry);
  prometheus::Family<prometheus::Histogram>& latency =
      prometheus::BuildHistogram()
          .Name("sceneloc_request_duration_seconds")
          .Help("From a request's arrival to its reply, by request kind (every status)")
          .Register(registry);
  prometheus::Family<prometheus::Histogram>& stages =
      prometheus::BuildHistogram()
          .Name("sceneloc_stage_duration_seconds")
          .Help("Each stage of the successful localise requests (Timings in the reply)")
          .Register(registry);
  prometheus::Counter& undelivered =
      prometheus::BuildCounter()
          .Name("sceneloc_replies_undelivered_total")
          .Help("Replies dropped because the client had gone or stopped reading")
          .Register(registry)
          .Add({});
};

Metrics::Metrics() : families_(std::make_unique<Families>()) {}
Metrics::~Metrics() = default;

void Metrics::RecordReply(const std::string& kind, const std::string& status,
                          const std::string& map, double latency_ms, const v1::Timings* timings) {
  families_->requests.Add({{"kind", kind}, {"status", status}, {"map", map}}).Increment();
  families_->latency.Add({{"kind", kind}}, LatencyBuckets()).Observe(latency_ms / 1000.0);
  if (timings == nullptr) return;
  for (const Stage& stage : kStages) {
    const double ms = (timings->*stage.ms)();
    // A stage the request did not run (decode for a feature set) is not a sample.
    if (ms > 0)
      families_->stages.Add({{"stage", stage.name}}, LatencyBuckets()).Observe(ms / 1000.0);
  }
}

void Metrics::RecordUndelivered() { families_->undelivered.Increment(); }

std::string Metrics::Render(const ServerGauges& gauges, const MapRegistry& maps) const {
  std::vector<MetricFamily> all = families_->registry.Collect();
  for (MetricFamily& family : Held(gauges, maps)) all.push_back(std::move(family));
  return prometheus::TextSerializer().Serialize(all);
}

}  // namespace sceneloc
