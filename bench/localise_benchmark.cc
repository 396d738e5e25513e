// Speed of the two per-frame stages the targets name, on real data when given:
//   extract   one 960x540 frame to features (both descriptors), one core
//   localise  features to a ranked answer (everything after extraction), 1 and 2 threads
//   hostile   a hostile query: N copies of the descriptor nearest the most landmarks (the
//             mean of them all) at one point, with
//             the default work budget (max_matches_per_landmark 32) and without it (0)
//   confidence  what the calibrated confidence adds to a localisation: the per-location
//             evidence scale and the posterior, for the camera in use alone (/0) and
//             averaged over cameras (/10, the default spread); the holistic distances and
//             the verified candidates it reads are computed for the ranking anyway
//
//   localise_benchmark [--map FILE --queries DIR] [benchmark flags]
//   e.g. --map gp.scnl --queries ../shared/data/gardens_point/day_right
//        --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// Without --map, a map is trained from a generated 960x540 tour (numbers then describe
// the synthetic scene, not the targets). Medians and p99 over queries: run with
// --benchmark_repetitions and read the aggregates; per-query spread is in sceneloc-eval.
#include <benchmark/benchmark.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <opencv2/imgcodecs.hpp>

#include "common/features/extractor.h"
#include "common/map/map_io.h"
#include "common/matching/confidence.h"
#include "common/matching/evidence.h"
#include "common/matching/holistic_similarity.h"
#include "common/matching/localiser.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"

namespace sceneloc {
namespace {

struct Fixture {
  Map map;
  std::vector<cv::Mat> images;      // query frames, decoded
  std::vector<FeatureSet> queries;  // their features
};

Fixture* fixture = nullptr;

void Fail(const std::string& m) {
  std::fprintf(stderr, "localise_benchmark: %s\n", m.c_str());
  std::exit(1);
}

void LoadReal(const std::string& map_path, const std::string& queries_dir) {
  auto map = LoadMap(map_path);
  if (!map.ok()) Fail(map.status().message());
  fixture->map = std::move(map).value();
  auto paths = ListImageFiles(queries_dir);
  if (!paths.ok()) Fail(paths.status().message());
  for (const auto& p : *paths) {
    auto image = ReadImageFile(p);
    if (!image.ok()) Fail(image.status().message());
    fixture->images.push_back(*image);
  }
}

void MakeSynthetic() {
  const std::string dir = std::filesystem::temp_directory_path() / "sceneloc_bench_tour";
  TourOptions tour;
  tour.num_locations = 40;
  tour.image_width = 960;
  tour.image_height = 540;
  if (!WriteTour(tour, dir, kTrainingPass).ok()) Fail("cannot write the generated tour");
  auto trained = TrainFromFolder(dir, TrainOptions(), 2, nullptr);
  if (!trained.ok()) Fail(trained.status().message());
  fixture->map = std::move(trained->map);
  auto test = RenderTourJpegs(tour, kTestPass);
  if (!test.ok()) Fail(test.status().message());
  for (const auto& jpeg : *test) fixture->images.push_back(*DecodeImage(jpeg, 8192));
  std::filesystem::remove_all(dir);
}

void BM_Extract(benchmark::State& state) {
  const auto extractor = FeatureExtractor::Create(fixture->map.options.extractor);
  size_t i = 0;
  for (auto _ : state) {
    const cv::Mat& image = fixture->images[i++ % fixture->images.size()];
    auto f = extractor->Extract(image, fixture->map.QueryTarget(image.cols, image.rows));
    benchmark::DoNotOptimize(f);
  }
  state.SetLabel(std::to_string(fixture->images[0].cols) + "x" +
                 std::to_string(fixture->images[0].rows));
}

void BM_Localise(benchmark::State& state) {
  ThreadPool pool(static_cast<int>(state.range(0)));
  MatchOptions options;
  size_t i = 0;
  for (auto _ : state) {
    auto r =
        Localise(fixture->queries[i++ % fixture->queries.size()], fixture->map, options, &pool);
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel(std::to_string(fixture->map.num_landmarks()) + " landmarks");
}

// The confidence's own cost, per query: LocationScores over every location and the
// calibrated posterior, from a localisation's candidates and holistic z-scores.
// Arg: confidence_scale_spread x 100 (0: the camera in use alone; 10: the default average
// over cameras).
void BM_Confidence(benchmark::State& state) {
  MatchOptions options;
  options.confidence_scale_spread = static_cast<double>(state.range(0)) / 100;
  struct Input {
    std::vector<CandidateEvidence> candidates;
    std::vector<float> holistic_z;
    float nearest = -1;
    int answer = 0;
  };
  std::vector<Input> inputs;
  for (const FeatureSet& q : fixture->queries) {
    auto r = Localise(q, fixture->map, options, nullptr);
    if (!r.ok() || r->ranked.empty()) continue;
    Input in;
    in.candidates = r->candidates;
    in.holistic_z = RobustZ(HolisticDistances(
        q, fixture->map, fixture->map.options.extractor.holistic.max_shift, nullptr));
    in.nearest = r->nearest_holistic_distance;
    in.answer = r->ranked[0].index;
    inputs.push_back(std::move(in));
  }
  if (inputs.empty()) {
    state.SkipWithError("no query localised");
    return;
  }
  size_t i = 0;
  for (auto _ : state) {
    const Input& in = inputs[i++ % inputs.size()];
    const std::vector<float> scores = LocationScores(
        in.candidates, in.holistic_z, static_cast<size_t>(fixture->map.num_images()), options);
    double c =
        CalibratedConfidence(fixture->map, scores, in.candidates, in.answer, in.nearest, options);
    benchmark::DoNotOptimize(c);
  }
  state.SetLabel(std::to_string(fixture->map.num_images()) + " locations");
}

void BM_HostileQuery(benchmark::State& state) {
  const Map& map = fixture->map;
  const int copies = static_cast<int>(state.range(0));
  FeatureSet f;
  f.image_width = map.image_width;
  f.image_height = map.image_height;
  f.keypoints.assign(static_cast<size_t>(copies), {100, 100, 4, 0, 1, 0});
  // The descriptor that resembles the most landmarks: the normalised mean of them all.
  const Eigen::RowVectorXf local = map.local_mean.cast<float>().colwise().mean().normalized();
  const Eigen::RowVectorXf context = map.context_mean.cast<float>().colwise().mean().normalized();
  f.local = local.replicate(copies, 1);
  f.context = context.replicate(copies, 1);
  MatchOptions options;
  options.max_matches_per_landmark = static_cast<int>(state.range(1));
  ThreadPool pool(2);
  size_t matches = 0;
  for (auto _ : state) {
    auto r = Localise(f, map, options, &pool);
    matches = r.ok() ? r->descriptor_matches : 0;
    benchmark::DoNotOptimize(r);
  }
  state.SetLabel(std::to_string(matches) + " matches kept");
}

BENCHMARK(BM_Extract)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Localise)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_Confidence)->Arg(0)->Arg(10)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_HostileQuery)
    ->Args({8192, 32})
    ->Args({1024, 32})
    ->Args({1024, 0})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(3);

}  // namespace
}  // namespace sceneloc

int main(int argc, char** argv) {
  std::string map_path, queries_dir;
  std::vector<char*> rest = {argv[0]};
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--map") == 0 && i + 1 < argc) {
      map_path = argv[++i];
    } else if (std::strcmp(argv[i], "--queries") == 0 && i + 1 < argc) {
      queries_dir = argv[++i];
    } else {
      rest.push_back(argv[i]);
    }
  }
  sceneloc::Fixture f;
  sceneloc::fixture = &f;
  if (!map_path.empty()) {
    sceneloc::LoadReal(map_path, queries_dir);
  } else {
    sceneloc::MakeSynthetic();
  }
  const auto extractor = sceneloc::FeatureExtractor::Create(f.map.options.extractor);
  for (const auto& image : f.images) {
    f.queries.push_back(*extractor->Extract(image, f.map.QueryTarget(image.cols, image.rows)));
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
