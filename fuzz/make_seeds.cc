// sceneloc-fuzz-seeds OUT [V1_MAP] [DATA_DIR]: writes the seed corpora of the fuzz targets,
// real inputs of every kind the server reads, into OUT/request (fuzz_request and
// fuzz_handler), OUT/jpeg and OUT/map:
//   request: list_maps, stats, reload_map, localise with a JPEG, and with feature sets
//            (float32 and uint8 descriptors, with and without the holistic descriptor),
//            also as a session (named, reset, carrying a state), all naming the fuzz map "m";
//   jpeg:    generated tour frames (baseline, progressive, grey, small), and up to 4
//            frames of each dev set in DATA_DIR (../shared/data) when it is there;
//   map:     the fuzz map as a whole file and as a payload, and V1_MAP (a format-1 map)
//            both ways;
//   session: the states of a session of a few frames on the fuzz map, in every
//            fuzz_session mode.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "common/features/extractor.h"
#include "common/map/map_io.h"
#include "common/matching/sequence_filter.h"
#include "common/util/image_folder.h"
#include "fuzz/fuzz_world.h"
#include "proto/sceneloc.pb.h"
#include "proto/wire.h"
#include "server/session_token.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

void Write(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    std::exit(1);
  }
}

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::string Encode(const cv::Mat& image, std::vector<int> params) {
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", image, bytes, params);
  return std::string(bytes.begin(), bytes.end());
}

void WriteRequestSeeds(const fuzz::FuzzWorld& world, const fs::path& dir) {
  int n = 0;
  auto write = [&](const v1::Request& r) {
    Write(dir / ("seed_" + std::to_string(n++)), r.SerializeAsString());
  };
  v1::Request r;
  r.set_request_id(7);
  r.mutable_list_maps();
  write(r);
  r.mutable_stats();
  write(r);
  r.mutable_reload_map()->set_map("m");
  write(r);
  r.mutable_localise()->set_map("m");
  r.mutable_localise()->set_top_k(3);
  r.mutable_localise()->set_jpeg(world.test_jpegs[2]);
  write(r);
  auto extractor = FeatureExtractor::Create(world.map.options.extractor);
  for (int i : {1, 4}) {
    auto image = DecodeImage(world.test_jpegs[static_cast<size_t>(i)], 4096);
    if (!image.ok()) std::exit(1);
    auto features = extractor->Extract(*image, world.map.QueryTarget(image->cols, image->rows));
    if (!features.ok()) std::exit(1);
    for (auto encoding : {DescriptorEncoding::kFloat32, DescriptorEncoding::kUint8}) {
      EncodeFeatureSet(*features, encoding, r.mutable_localise()->mutable_features());
      r.mutable_localise()->set_min_confidence(0.5f);
      write(r);
      r.mutable_localise()->mutable_features()->clear_holistic();
      write(r);
    }
  }
  // A robot's session: named, reset, and with a carried state (one that fails its checks).
  r.mutable_localise()->set_session("robot-1");
  write(r);
  r.mutable_localise()->set_reset_session(true);
  write(r);
  r.mutable_localise()->set_reset_session(false);
  r.mutable_localise()->set_session_state(std::string("SLS1") + std::string(80, '\x01'));
  write(r);
  // A stated camera: in a session, and on its own.
  r.mutable_localise()->clear_session_state();
  r.mutable_localise()->set_camera_scale(1.33f);
  write(r);
  r.mutable_localise()->clear_session();
  write(r);
}

void WriteJpegSeeds(const fuzz::FuzzWorld& world, const std::string& data_dir,
                    const fs::path& dir) {
  int n = 0;
  auto write = [&](const std::string& jpeg) { Write(dir / ("seed_" + std::to_string(n++)), jpeg); };
  write(world.tour_jpegs[0]);
  write(world.test_jpegs[3]);
  auto image = DecodeImage(world.tour_jpegs[1], 4096);
  if (!image.ok()) std::exit(1);
  write(Encode(*image, {cv::IMWRITE_JPEG_PROGRESSIVE, 1, cv::IMWRITE_JPEG_QUALITY, 70}));
  cv::Mat grey, small;
  cv::cvtColor(*image, grey, cv::COLOR_BGR2GRAY);
  write(Encode(grey, {cv::IMWRITE_JPEG_QUALITY, 50}));
  cv::resize(*image, small, cv::Size(40, 30));
  write(Encode(small, {cv::IMWRITE_JPEG_QUALITY, 30}));
  if (data_dir.empty() || !fs::is_directory(data_dir)) return;
  for (const char* set :
       {"gardens_point/day_right", "gardens_point/night_right", "corridor/query"}) {
    auto files = ListImageFiles(data_dir + "/" + set);
    if (!files.ok()) continue;
    for (size_t i = 0; i < files->size() && i < 4; ++i) write(ReadAll((*files)[i]));
  }
}

void WriteMapSeeds(const fuzz::FuzzWorld& world, const std::string& v1_map, const fs::path& dir) {
  auto write = [&](const char* name, uint8_t mode, const std::string& bytes) {
    Write(dir / name, std::string(1, static_cast<char>(mode)) + bytes);
  };
  const std::string file = SerializeMap(world.map);
  write("v2_file", fuzz::kMapModeWholeFile, file);
  write("v2_payload", fuzz::kMapModePayloadV2, file.substr(kMapHeaderBytes));
  if (v1_map.empty()) return;
  const std::string v1 = ReadAll(v1_map);
  if (v1.size() <= kMapHeaderBytes) {
    std::fprintf(stderr, "%s is not a map file\n", v1_map.c_str());
    std::exit(1);
  }
  write("v1_file", fuzz::kMapModeWholeFile, v1);
  write("v1_payload", fuzz::kMapModePayloadV1, v1.substr(kMapHeaderBytes));
}

void WriteSessionSeeds(const fuzz::FuzzWorld& world, const fs::path& dir) {
  const int n = world.map.num_images();
  for (const int mode : {0, 1, 2, 3}) {  // fuzz::kSessionModeFixCrc | kSessionModeFewTracked
    SequenceOptions options;
    if ((mode & fuzz::kSessionModeFewTracked) != 0) {
      options.tracked_locations = fuzz::kSessionFewTracked;
    }
    const SequenceFilter filter(world.map, options);
    const TokenOwner owner{fuzz::kSessionClient, fuzz::kSessionName, fuzz::kSessionMapChecksum, n,
                           filter.num_speeds()};
    SequenceState state;
    for (int t = 0; t < 3; ++t) {
      FrameEvidence frame;
      frame.in_map = 0.8;
      for (int l = 0; l < n; ++l) frame.location_scores.push_back(l == t ? 4.0f : 0.0f);
      filter.Update(frame, &state);
      Write(dir / ("mode" + std::to_string(mode) + "_frame" + std::to_string(t)),
            std::string(1, static_cast<char>(mode)) + SerializeSessionToken(state, owner));
    }
  }
}

}  // namespace
}  // namespace sceneloc

int main(int argc, char** argv) {
  using namespace sceneloc;
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s OUT_DIR [V1_MAP] [DATA_DIR]\n", argv[0]);
    return 2;
  }
  const fs::path out = argv[1];
  auto world = fuzz::MakeFuzzWorld();
  if (!world.ok()) {
    std::fprintf(stderr, "%s\n", world.status().ToString().c_str());
    return 1;
  }
  for (const char* d : {"request", "jpeg", "map", "session"}) fs::create_directories(out / d);
  WriteRequestSeeds(*world, out / "request");
  WriteJpegSeeds(*world, argc > 3 ? argv[3] : "", out / "jpeg");
  WriteMapSeeds(*world, argc > 2 ? argv[2] : "", out / "map");
  WriteSessionSeeds(*world, out / "session");
  std::printf("seeds written to %s\n", out.c_str());
  return 0;
}
