// Places and experiences of a map (map.h): checks and what is derived from them. Internal to
// the map library (Map::Validate and Map::Finalize call these).
#pragma once

#include <cstddef>

#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc {

// How many places `map.image_place` names (the image count when it is empty), without
// Finalize. Meaningful only when ValidatePlaces(map) is OK.
size_t CountPlaces(const Map& map);

// Checks image_place (one entry per image, every place in [0, P) shown by some image, and
// the places in order of their first image) and the experiences (in image order, covering
// every image, kinds known).
Status ValidatePlaces(const Map& map);

// Fills map->place_image from image_place. REQUIRES: ValidatePlaces(*map).ok().
void DerivePlaces(Map* map);

}  // namespace sceneloc
