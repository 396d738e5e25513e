// The latency floor: every stage of a JPEG localisation beside plain SIFT on the same frames,
// in one run, so that each figure is a ratio to what this machine can do at best.
//
//   floor      cv::SIFT detectAndCompute on the grey working frame: one pyramid, the local
//              descriptors only, one thread (what no extractor of ours can beat alone)
//   decode     JPEG to the grey working frame: in full colour, then grey and resized (the
//              old path), and straight to grey at the reduced DCT size, by imgcodecs and by
//              DecodeGray (common/image: TurboJPEG)
//   extract    ours (both descriptors) on the working frame, one thread and with OpenCV's
//              loops on a 2-thread pool (opencv_threads.h); and the two-pass extraction
//              (detect, then compute over 2N keypoints) for comparison
//   localise   features to a ranked answer, 1 and 2 threads
//   end-to-end decode + extract + localise in-process, one thread and on the pool
//
//   latency_floor [--map FILE --queries DIR] [--frames N] [--rounds R]
// Without --map, a map is trained from a generated 960x540 tour. Prints medians, p99 and the
// ratio of each median to the floor's. Run on a quiet machine: one measurement at a time.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "common/features/extractor.h"
#include "common/features/opencv_threads.h"
#include "common/features/sift_describer.h"
#include "common/features/sift_detector.h"
#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"
#include "common/util/image_folder.h"
#include "common/util/malloc_policy.h"
#include "common/util/thread_pool.h"

namespace sceneloc {
namespace {

[[noreturn]] void Fail(const std::string& m) {
  std::fprintf(stderr, "latency_floor: %s\n", m.c_str());
  std::exit(1);
}

template <typename T>
T Must(StatusOr<T> v) {
  if (!v.ok()) Fail(v.status().message());
  return std::move(v).value();
}

struct Input {
  Map map;
  std::vector<std::string> jpegs;
  std::vector<std::string> names;  // file names (a generated tour's follow the tour)
};

Input Synthetic(int frames) {
  const std::string dir =
      (std::filesystem::temp_directory_path() / "sceneloc_latency_floor_tour").string();
  TourOptions tour;
  tour.num_locations = std::max(10, frames);
  tour.image_width = 960;
  tour.image_height = 540;
  if (!WriteTour(tour, dir, kTrainingPass).ok()) Fail("cannot write the generated tour");
  Input in;
  in.map = Must(TrainFromFolder(dir, TrainOptions(), 2, nullptr)).map;
  std::filesystem::remove_all(dir);
  in.jpegs = Must(RenderTourJpegs(tour, kTestPass));
  for (size_t i = 0; i < in.jpegs.size(); ++i)
    in.names.push_back(TourImageName(static_cast<int>(i)));
  return in;
}

Input Real(const std::string& map_path, const std::string& queries) {
  Input in;
  in.map = Must(LoadMap(map_path));
  for (const std::string& path : Must(ListImageFiles(queries))) {
    std::ifstream file(path, std::ios::binary);
    in.jpegs.emplace_back(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
    in.names.push_back(std::filesystem::path(path).filename().string());
  }
  return in;
}

// The two-pass extraction: detect, then compute local and context descriptors of
// the 2N keypoints in one call (a second pyramid, the context windows on the keypoint's
// own octave).
void TwoPassExtract(const cv::Mat& gray, const ExtractorOptions& o) {
  auto sift = cv::SIFT::create(o.max_features, 3, o.contrast_threshold, o.edge_threshold, o.sigma);
  std::vector<cv::KeyPoint> k;
  sift->detect(gray, k);
  const size_t n = k.size();
  for (size_t i = 0; i < n; ++i) {
    cv::KeyPoint wide = k[i];
    wide.size *= static_cast<float>(o.context_scale);
    k.push_back(wide);
  }
  cv::Mat d;
  sift->compute(gray, k, d);
}

cv::Mat FullDecode(const std::string& jpeg, const ExtractionTarget& t) {
  cv::Mat colour = Must(DecodeImage(jpeg, 8192)), gray, out;
  cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
  cv::resize(gray, out, cv::Size(t.width, t.height), 0, 0, cv::INTER_AREA);
  return out;
}

cv::Mat ReducedDecode(const std::string& jpeg, const ExtractionTarget& t, int w, int h) {
  cv::Mat gray = Must(DecodeGray(jpeg, 8192, DecodeReduction(w, h, t))), out;
  cv::resize(gray, out, cv::Size(t.width, t.height), 0, 0, cv::INTER_AREA);
  return out;
}

// The same reduced decode through OpenCV's imgcodecs, which the programs used before
// common/image: the two stages side by side say what the codec costs or saves.
cv::Mat ImgcodecsReducedDecode(const std::string& jpeg, const ExtractionTarget& t, int w, int h) {
  const int reduction = DecodeReduction(w, h, t);
  const int flags = reduction == 8   ? cv::IMREAD_REDUCED_GRAYSCALE_8
                    : reduction == 4 ? cv::IMREAD_REDUCED_GRAYSCALE_4
                    : reduction == 2 ? cv::IMREAD_REDUCED_GRAYSCALE_2
                                     : cv::IMREAD_GRAYSCALE;
  const cv::Mat buffer(1, static_cast<int>(jpeg.size()), CV_8U, const_cast<char*>(jpeg.data()));
  cv::Mat gray = cv::imdecode(buffer, flags), out;
  cv::resize(gray, out, cv::Size(t.width, t.height), 0, 0, cv::INTER_AREA);
  return out;
}

struct Stage {
  std::string name;
  std::function<void(size_t frame)> run;
  std::vector<double> ms;
};

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())))];
}

// Per frame: its header size, target, working frame and features, made once.
struct Frame {
  int width = 0, height = 0;
  ExtractionTarget target;
  cv::Mat gray;
  FeatureSet features;
};

std::vector<Frame> MakeFrames(const Input& in, const FeatureExtractor& extractor) {
  std::vector<Frame> f(in.jpegs.size());
  for (size_t i = 0; i < f.size(); ++i) {
    const cv::Mat colour = Must(DecodeImage(in.jpegs[i], 8192));
    f[i].width = colour.cols;
    f[i].height = colour.rows;
    f[i].target = in.map.QueryTarget(colour.cols, colour.rows);
    f[i].gray = FullDecode(in.jpegs[i], f[i].target);
    f[i].features = Must(extractor.Extract(f[i].gray, f[i].target));
  }
  return f;
}

// What every stage works on: the input, its frames, the extractor and the pools (made
// last, so no pool thread exists while the frames are made).
struct Setup {
  explicit Setup(Input input)
      : in(std::move(input)),
        extractor(FeatureExtractor::Create(in.map.options.extractor)),
        f(MakeFrames(in, *extractor)) {}

  Input in;
  std::unique_ptr<FeatureExtractor> extractor;
  std::vector<Frame> f;
  ThreadPool one{1}, two{2};
  MatchOptions match;
};

// The stages measured, the floor first. Stages that use the 2-thread pool for OpenCV's
// loops say so ("[pool]"); the switch happens around them (OpenCvOnThreadPool) so every
// other stage runs OpenCV on one thread.
std::vector<Stage> MakeStages(Setup& s) {
  const ExtractorOptions& eo = s.in.map.options.extractor;
  auto localise = [&s](size_t i, ThreadPool* pool) {
    Must(Localise(s.f[i].features, s.in.map, s.match, pool));
  };
  auto end_to_end = [&s](size_t i, ThreadPool* pool) {
    const Frame& f = s.f[i];
    const cv::Mat gray = ReducedDecode(s.in.jpegs[i], f.target, f.width, f.height);
    const FeatureSet features = Must(s.extractor->Extract(gray, f.target));
    Must(Localise(features, s.in.map, s.match, pool));
  };
  auto floor = [&s, &eo](size_t i) {
    auto sift =
        cv::SIFT::create(eo.max_features, 3, eo.contrast_threshold, eo.edge_threshold, eo.sigma);
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    sift->detectAndCompute(s.f[i].gray, cv::noArray(), k, d);
  };
  auto strips = [&s, &eo](size_t i) {
    std::vector<cv::KeyPoint> k;
    cv::Mat d;
    SiftParameters p;
    p.max_features = eo.max_features;
    p.contrast_threshold = eo.contrast_threshold;
    p.edge_threshold = eo.edge_threshold;
    p.sigma = eo.sigma;
    DetectAndDescribeSift(s.f[i].gray, p, &k, &d);
  };
  return {
      {"floor: SIFT detectAndCompute, 1 thread", floor, {}},
      {"floor on a pool of 2 [pool]", floor, {}},
      {"SIFT in strips (ours), 1 thread", strips, {}},
      {"SIFT in strips (ours), pool of 2 [pool]", strips, {}},
      {"decode: colour, grey, resize (before)",
       [&s](size_t i) { FullDecode(s.in.jpegs[i], s.f[i].target); },
       {}},
      {"decode: reduced grey, resize (imgcodecs)",
       [&s](size_t i) {
         ImgcodecsReducedDecode(s.in.jpegs[i], s.f[i].target, s.f[i].width, s.f[i].height);
       },
       {}},
      {"decode: reduced grey, resize",
       [&s](size_t i) { ReducedDecode(s.in.jpegs[i], s.f[i].target, s.f[i].width, s.f[i].height); },
       {}},
      {"extract: two passes (before), 1 thread",
       [&s, &eo](size_t i) { TwoPassExtract(s.f[i].gray, eo); },
       {}},
      {"context pass: SIFT compute (before), 1 thread",
       [&s, &eo](size_t i) {
         std::vector<cv::KeyPoint> k = ContextKeypoints(s.f[i].features, eo);
         cv::Mat d;
         cv::SIFT::create(eo.max_features, eo.octave_layers, eo.contrast_threshold,
                          eo.edge_threshold, eo.sigma)
             ->compute(s.f[i].gray, k, d);
       },
       {}},
      {"context pass: own pyramid, 1 thread",
       [&s, &eo](size_t i) {
         DescribeSiftKeypoints(s.f[i].gray, ContextKeypoints(s.f[i].features, eo), eo.octave_layers,
                               eo.sigma);
       },
       {}},
      {"extract: 1 thread",
       [&s](size_t i) { Must(s.extractor->Extract(s.f[i].gray, s.f[i].target)); },
       {}},
      {"extract: pool of 2 [pool]",
       [&s](size_t i) { Must(s.extractor->Extract(s.f[i].gray, s.f[i].target)); },
       {}},
      {"localise: 1 thread", [&s, localise](size_t i) { localise(i, &s.one); }, {}},
      {"localise: pool of 2", [&s, localise](size_t i) { localise(i, &s.two); }, {}},
      {"end-to-end: 1 thread", [&s, end_to_end](size_t i) { end_to_end(i, &s.one); }, {}},
      {"end-to-end: pool of 2 [pool]", [&s, end_to_end](size_t i) { end_to_end(i, &s.two); }, {}},
  };
}

// Runs every stage on every frame, `rounds` times, recording each run's milliseconds.
void Measure(Setup& s, int rounds, std::vector<Stage>* stages) {
  for (int r = 0; r < rounds; ++r) {
    for (size_t i = 0; i < s.f.size(); ++i) {
      for (Stage& stage : *stages) {  // every stage on the same frame in turn: shared noise
        const bool pooled = stage.name.find("[pool]") != std::string::npos;
        std::unique_ptr<OpenCvOnThreadPool> on_pool;
        if (pooled) on_pool = std::make_unique<OpenCvOnThreadPool>(&s.two);
        const auto start = std::chrono::steady_clock::now();
        stage.run(i);
        stage.ms.push_back(
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                .count());
      }
    }
  }
}

// The answers of both decodes, against the tour image of the query's own name (Gardens
// Point and the corridor name a query after its place): the reduced decode must not
// cost accuracy. Also localise's own stages, one thread.
struct Agreement {
  int truths = 0, right_full = 0, right_reduced = 0, same = 0;
  std::vector<double> stage_ms[5];
};

Agreement CompareDecodes(Setup& s) {
  Agreement g;
  for (size_t i = 0; i < s.f.size(); ++i) {
    const Frame& f = s.f[i];
    const cv::Mat reduced = ReducedDecode(s.in.jpegs[i], f.target, f.width, f.height);
    const auto a = Must(Localise(f.features, s.in.map, s.match, nullptr));
    const auto b =
        Must(Localise(Must(s.extractor->Extract(reduced, f.target)), s.in.map, s.match, nullptr));
    const StageTimings& st = a.timings;
    const double ms[5] = {st.descriptor_ms, st.neighbourhood_ms, st.likelihood_ms, st.holistic_ms,
                          st.verify_ms};
    for (int k = 0; k < 5; ++k) g.stage_ms[k].push_back(ms[k]);
    if (a.ranked.empty() || b.ranked.empty()) continue;
    g.same += a.ranked[0].index == b.ranked[0].index;
    const auto& names = s.in.map.image_names;
    const auto truth = std::find(names.begin(), names.end(), s.in.names[i]);
    if (truth == names.end()) continue;
    const int t = static_cast<int>(truth - names.begin());
    ++g.truths;
    g.right_full += std::abs(a.ranked[0].index - t) <= 2;
    g.right_reduced += std::abs(b.ranked[0].index - t) <= 2;
  }
  return g;
}

void PrintResults(const Setup& s, int rounds, const std::vector<Stage>& stages,
                  const Agreement& g) {
  const double floor = Quantile(stages[0].ms, 0.5);
  std::printf("%zu frames of %dx%d, working frame %dx%d, %d landmarks, %d rounds\n", s.f.size(),
              s.f[0].width, s.f[0].height, s.f[0].target.width, s.f[0].target.height,
              s.in.map.num_landmarks(), rounds);
  std::printf("%-42s %9s %9s %9s\n", "stage", "p50 ms", "p99 ms", "p50/floor");
  for (const Stage& stage : stages) {
    const double p50 = Quantile(stage.ms, 0.5);
    std::printf("%-42s %9.2f %9.2f %9.2f\n", stage.name.c_str(), p50, Quantile(stage.ms, 0.99),
                p50 / floor);
  }
  const char* stage_names[5] = {"descriptor (S_D)", "neighbourhood (S_N)", "likelihood", "holistic",
                                "verification"};
  std::printf("localise stages, 1 thread, p50 ms:");
  for (int k = 0; k < 5; ++k) std::printf(" %s %.2f", stage_names[k], Quantile(g.stage_ms[k], 0.5));
  std::printf("\n");
  std::printf("answers: reduced and full decode agree on %d of %zu frames", g.same, s.f.size());
  if (g.truths > 0) {
    std::printf("; within 2 of the same-named tour image: full %d, reduced %d of %d", g.right_full,
                g.right_reduced, g.truths);
  }
  std::printf("\n");
}

}  // namespace
}  // namespace sceneloc

int main(int argc, char** argv) {
  using namespace sceneloc;
  CLI::App app{"latency_floor: each stage of a JPEG localisation as a ratio to plain SIFT"};
  std::string map_path, queries;
  int frames = 40, rounds = 3;
  app.add_option("--map", map_path, "map file (default: trained from a generated tour)");
  app.add_option("--queries", queries, "folder of query JPEGs (with --map)");
  app.add_option("--frames", frames, "frames measured")->check(CLI::Range(1, 100000));
  app.add_option("--rounds", rounds, "passes over the frames")->check(CLI::Range(1, 1000));
  CLI11_PARSE(app, argc, argv);
  if (map_path.empty() != queries.empty()) Fail("--map and --queries go together");
  UseServingMallocPolicy();  // as the server: per-request buffers reused, not faulted in
  OpenCvSerial();

  Input in = map_path.empty() ? Synthetic(frames) : Real(map_path, queries);
  if (in.jpegs.empty()) Fail("no query frames");
  if (static_cast<int>(in.jpegs.size()) > frames) in.jpegs.resize(static_cast<size_t>(frames));
  Setup s(std::move(in));
  std::vector<Stage> stages = MakeStages(s);
  Measure(s, rounds, &stages);
  const Agreement agreement = CompareDecodes(s);
  PrintResults(s, rounds, stages, agreement);
  return 0;
}
