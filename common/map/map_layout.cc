#include "common/map/map_layout.h"

#include <algorithm>
#include <cmath>

namespace sceneloc::map_io_internal {

void UpgradeV1(const V1Fields& v1, Map* map) {
  TrainOptions& o = map->options;
  const double long_side = std::max(1, map->frame_long_side());
  o.extractor.working_size = map->frame_long_side();
  o.extractor.holistic.cols = 0;
  o.ransac_threshold = v1.ransac_threshold_px / long_side;
  o.distance_sd_floor = std::sqrt(std::max(0.0, v1.distance_var_floor)) / long_side;
  o.min_landmarks_per_image = 0;
}

}  // namespace sceneloc::map_io_internal
