#include "client/bench_command.h"

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "client/client_extractor.h"
#include "client/load_generator.h"
#include "common/config/config.h"
#include "common/features/extractor.h"
#include "common/map/map_io.h"
#include "common/util/image_folder.h"
#include "common/util/timer.h"

namespace sceneloc {
namespace {

StatusOr<std::string> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFound("cannot read '" + path + "'");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// The feature set of one image file's bytes.
StatusOr<FeatureSet> ExtractFile(const ClientExtractor& extractor, const std::string& bytes) {
  SCENELOC_ASSIGN_OR_RETURN(const cv::Mat image,
                            DecodeImage(bytes, extractor.options().max_image_side));
  return extractor.Extract(image);
}

// Every image of the folder as a ready request: read (and extracted) once, here. An image
// that cannot be decoded or extracted fails the whole preparation, naming its file.
StatusOr<std::vector<LoadQuery>> PrepareQueries(const BenchArgs& args) {
  SCENELOC_ASSIGN_OR_RETURN(const std::vector<std::string> paths, ListImageFiles(args.image_dir));
  std::optional<ClientExtractor> extractor;
  if (args.features) {
    auto created = ClientExtractor::Create({args.map_file, args.config, args.working_size});
    if (!created.ok()) return created.status();
    extractor = std::move(created).value();
  }
  std::vector<LoadQuery> queries;
  for (const std::string& path : paths) {
    SCENELOC_ASSIGN_OR_RETURN(std::string bytes, ReadBytes(path));
    if (!extractor) {
      queries.push_back(JpegQuery(FileName(path), std::move(bytes)));
      continue;
    }
    auto features = ExtractFile(*extractor, bytes);
    if (!features.ok()) {
      return Status(features.status().code(), path + ": " + features.status().message());
    }
    queries.push_back(
        FeatureQuery(FileName(path), *features,
                     args.uint8 ? DescriptorEncoding::kUint8 : DescriptorEncoding::kFloat32));
  }
  return queries;
}

nlohmann::json Percentiles(const std::vector<double>& values) {
  return {{"p50", Quantile(values, 0.50)},
          {"p90", Quantile(values, 0.90)},
          {"p99", Quantile(values, 0.99)},
          {"max", Quantile(values, 1.0)}};
}

nlohmann::json StagePercentiles(const LoadResult& r) {
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [stage, values] : r.stage_ms) stages[stage] = Percentiles(values);
  return stages;
}

nlohmann::json ToJson(const BenchArgs& args, const LoadResult& r) {
  nlohmann::json versions = nlohmann::json::array(), checksums = nlohmann::json::object();
  for (const auto& [generation, checksum] : r.map_versions) {
    versions.push_back(generation);
    char hex[9];
    std::snprintf(hex, sizeof(hex), "%08x", checksum);
    checksums[std::to_string(generation)] = hex;
  }
  return {{"requests", r.requests},
          {"ok", r.ok},
          {"throughput_rps", r.ThroughputRps()},
          {"elapsed_s", r.elapsed_s},
          {"clients", args.clients},
          {"duration_s", args.duration_s},
          {"mode", args.features ? "features" : "jpeg"},
          {"descriptors", args.features ? (args.uint8 ? "uint8" : "float32") : ""},
          {"map", args.map},
          {"latency_ms", Percentiles(r.latency_ms)},
          {"server_ms", Percentiles(r.server_ms)},
          {"outside_ms", Percentiles(r.outside_ms)},
          {"server_stage_ms", StagePercentiles(r)},
          {"errors", r.errors},
          {"retries", r.retries},
          {"sessions", args.sessions},
          {"session_localised", r.session_localised},
          {"map_versions", versions},
          {"map_checksums", checksums}};
}

void PrintSummary(const BenchArgs& args, const LoadResult& r) {
  std::printf("bench: %s, %d client(s), %.1f s, %s requests to map %s\n", args.endpoint.c_str(),
              args.clients, r.elapsed_s, args.features ? "feature-set" : "JPEG", args.map.c_str());
  std::printf("requests    %lld (%lld ok)\n", static_cast<long long>(r.requests),
              static_cast<long long>(r.ok));
  std::printf("throughput  %.2f req/s\n", r.ThroughputRps());
  std::printf("latency ms  p50 %.2f  p90 %.2f  p99 %.2f  max %.2f  (client, successful requests)\n",
              Quantile(r.latency_ms, 0.5), Quantile(r.latency_ms, 0.9),
              Quantile(r.latency_ms, 0.99), Quantile(r.latency_ms, 1.0));
  std::printf("server ms   p50 %.2f  p90 %.2f  p99 %.2f\n", Quantile(r.server_ms, 0.5),
              Quantile(r.server_ms, 0.9), Quantile(r.server_ms, 0.99));
  std::printf(
      "outside ms  p50 %.3f  p90 %.3f  p99 %.3f  (each request's latency less its server "
      "time: network, broker, client)\n",
      Quantile(r.outside_ms, 0.5), Quantile(r.outside_ms, 0.9), Quantile(r.outside_ms, 0.99));
  if (!r.stage_ms.empty()) {
    // In the order a request passes them; each median on its own (they do not add up).
    std::printf("server p50  ");
    for (const char* stage : {"queue", "decode", "extract", "descriptor", "neighbourhood",
                              "likelihood", "holistic", "verify"}) {
      const auto it = r.stage_ms.find(stage);
      if (it != r.stage_ms.end()) std::printf(" %s %.2f", stage, Quantile(it->second, 0.5));
    }
    std::printf("  (ms, per stage)\n");
  }
  if (args.sessions) {
    std::printf("sessions    one per client, in folder order: %lld of %lld answers LOCALISED\n",
                static_cast<long long>(r.session_localised), static_cast<long long>(r.ok));
  }
  std::printf("errors     ");
  if (r.errors.empty()) std::printf(" none");
  for (const auto& [kind, n] : r.errors)
    std::printf(" %s %lld", kind.c_str(), static_cast<long long>(n));
  if (r.retries > 0) std::printf("\nretried     %lld attempts", static_cast<long long>(r.retries));
  std::printf("\nmap versions");
  for (const auto& [generation, checksum] : r.map_versions) {
    std::printf(" %s@%llu (%08x)", args.map.c_str(), static_cast<unsigned long long>(generation),
                checksum);
  }
  std::printf("\n");
}

}  // namespace

int RunBench(const BenchArgs& args) {
  LoadOptions options;
  options.endpoint = args.endpoint;
  options.map = args.map;
  options.clients = args.clients;
  options.duration_s = args.duration_s;
  options.timeout_ms = args.timeout_ms;
  options.retries = args.retries;
  options.top_k = args.top_k;
  options.sessions = args.sessions;
  options.key_file = args.key_file;
  options.server_key_file = args.server_key_file;
  if (const Status valid = options.Validate(); !valid.ok()) {
    std::fprintf(stderr, "sceneloc bench: %s\n", valid.message().c_str());
    return 2;
  }
  const Stopwatch preparing;
  auto queries = PrepareQueries(args);
  if (!queries.ok()) {
    std::fprintf(stderr, "sceneloc bench: %s\n", queries.status().message().c_str());
    return 2;
  }
  std::printf("bench: %zu queries prepared in %.1f s (%s); sending for %g s\n", queries->size(),
              preparing.Seconds(), args.features ? "read and extracted" : "read", args.duration_s);
  std::fflush(stdout);
  auto result = RunLoad(options, *queries);
  if (!result.ok()) {
    std::fprintf(stderr, "sceneloc bench: %s\n", result.status().message().c_str());
    return 2;
  }
  PrintSummary(args, *result);
  if (!args.json_out.empty()) {
    std::ofstream out(args.json_out);
    out << ToJson(args, *result).dump(2) << "\n";
    if (!out) {
      std::fprintf(stderr, "sceneloc bench: cannot write '%s'\n", args.json_out.c_str());
      return 2;
    }
  }
  return result->errors.empty() && result->requests > 0 ? 0 : 1;
}

}  // namespace sceneloc
