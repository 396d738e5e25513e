// Landmark selection (paper IV): the iterative eta-per-image algorithm.
//   1. Find the image I_min with the fewest landmarks assigned, eta_min. If eta_min >= eta,
//      stop.
//   2. Of the unselected landmarks seen in I_min with Q > q_min, take the eta - eta_min of
//      highest Q.
//   3. Select them (each counts for every image it was seen in) and go back to 1.
// An image with no eligible landmark left is set aside, so the loop ends even when an
// image cannot reach eta (the paper's q_min note).
#pragma once

#include <cstdint>
#include <vector>

namespace sceneloc {

// landmark_images[g] = the tour images landmark g was seen in. eta == 0 selects every
// landmark with quality > q_min. Returns the selected landmark indices, ascending.
std::vector<uint32_t> SelectLandmarks(const std::vector<std::vector<uint32_t>>& landmark_images,
                                      const std::vector<float>& quality, int num_images, int eta,
                                      double q_min);

}  // namespace sceneloc
