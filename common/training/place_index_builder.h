// Builds a map's place index (common/map/place_index.h) at training: the vocabulary of
// visual words by two levels of k-means over the landmarks' local means, every landmark's
// word, and the codes of the tour's holistic descriptors (place_index.h HolisticCodes).
//
// Deterministic for the same map (seeded sampling); thread-compatible.
#pragma once

#include "common/map/map.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// Words per coarse cell and cells: sqrt(landmarks / 16) each, within [8, 128] (16,384 words
// at most), so a word holds a few dozen landmarks whatever the map's size.
int VocabularySide(size_t num_landmarks);

// Fills map->place_index when the map has at least options.place_index_min_locations
// locations (and that setting is not 0); else leaves it empty. `pool` may be null.
// REQUIRES: the landmarks, image lists and holistic descriptors are filled.
void BuildPlaceIndex(Map* map, ThreadPool* pool);

}  // namespace sceneloc
