// Co-occurrence and spatial statistics (paper III-B): for each landmark g, its neighbours
// g' (landmarks seen in at least one tour image together with g), p(g'|g), and the mean,
// variance and largest deviation of the distance and angle from g to g' over the images
// that hold both. Only the max_neighbours nearest (by mean position) are kept, nearest
// first, which is the order eq. 2 walks them in.
#pragma once

#include "common/map/map.h"

namespace sceneloc {

// Fills map->neighbour_offsets and map->neighbours from the landmarks' observations.
// REQUIRES: landmark arrays and observations are filled; observations of a landmark are in
// ascending image order.
void BuildNeighbours(const TrainOptions& options, Map* map);

// Fills map->image_offsets / image_landmarks (G_l) from the observations.
void BuildImageLists(Map* map);

}  // namespace sceneloc
