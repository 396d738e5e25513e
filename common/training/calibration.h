// Training-time calibration of the confidence (common/matching/confidence.h): what the map
// needs to know about its tour to tell a frame of the route from a frame of somewhere else.
//
// A frame that shows no place of the route, but comes from the same camera and the same kind
// of scene, is made from every tour image by turning it upside down: its holistic descriptor
// is the tour image's with the cell grid reversed and each orientation histogram turned by
// half a circle (RotateHolistic180), no image needed. How close such frames come to the tour's
// images (their smallest holistic distance) is the map's off-map level.
#pragma once

#include <vector>

#include "common/map/map.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// The holistic descriptor of the image turned by 180 degrees. REQUIRES: `h` holds
// grid.size() values and grid.bins is even.
std::vector<float> RotateHolistic180(const float* h, const HolisticGrid& grid);

// Fills map->calibration from the map's own holistic descriptors, measuring at most
// `max_samples` tour images (evenly spaced). A map without holistic descriptors gets an
// invalid calibration (the paper's confidence then). `pool` may be null.
void CalibrateMap(Map* map, ThreadPool* pool, int max_samples = 200);

// The same level for the images [first, first + count) alone (one walk of the map,
// map.h Experience): their turned frames against those images only.
// REQUIRES: the range lies within the map's images, count > 0.
Calibration CalibrateImages(const Map& map, int first, int count, ThreadPool* pool,
                            int max_samples = 200);

}  // namespace sceneloc
