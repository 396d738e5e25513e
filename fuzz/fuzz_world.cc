#include "fuzz/fuzz_world.h"

#include <cstring>

#include "common/features/extractor.h"
#include "common/map/crc32.h"
#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"
#include "common/training/trainer.h"

namespace sceneloc::fuzz {

StatusOr<FuzzWorld> MakeFuzzWorld() {
  TourOptions tour;
  tour.num_locations = 6;
  tour.image_width = 320;
  tour.image_height = 240;
  FuzzWorld world;
  SCENELOC_ASSIGN_OR_RETURN(world.tour_jpegs, RenderTourJpegs(tour, kTrainingPass));
  SCENELOC_ASSIGN_OR_RETURN(world.test_jpegs, RenderTourJpegs(tour, kTestPass));

  TrainOptions options;
  options.extractor.working_size = 320;
  options.extractor.max_features = 300;
  auto extractor = FeatureExtractor::Create(options.extractor);
  std::vector<FeatureSet> features;
  std::vector<std::string> names;
  for (size_t i = 0; i < world.tour_jpegs.size(); ++i) {
    SCENELOC_ASSIGN_OR_RETURN(const cv::Mat image, DecodeImage(world.tour_jpegs[i], 4096));
    SCENELOC_ASSIGN_OR_RETURN(FeatureSet f, extractor->ExtractTour(image));
    features.push_back(std::move(f));
    names.push_back(TourImageName(static_cast<int>(i)));
  }
  SCENELOC_ASSIGN_OR_RETURN(TrainResult trained,
                            TrainFromFeatures(features, names, options, 1, nullptr));
  world.map = std::move(trained.map);
  return world;
}

std::string WithHeader(const std::string& payload, uint32_t format_version) {
  std::string file(kMapHeaderBytes, '\0');
  char* h = file.data();
  const uint32_t flags = 0;
  const uint64_t size = payload.size();
  const uint32_t payload_crc = Crc32(payload.data(), payload.size());
  std::memcpy(h, kMapMagic, 8);  // the file format is little-endian, as is every target we build
  std::memcpy(h + 8, &format_version, 4);
  std::memcpy(h + 12, &flags, 4);
  std::memcpy(h + 16, &size, 8);
  std::memcpy(h + 24, &payload_crc, 4);
  const uint32_t header_crc = Crc32(h, 28);
  std::memcpy(h + 28, &header_crc, 4);
  return file + payload;
}

}  // namespace sceneloc::fuzz
