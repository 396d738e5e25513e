// The coarse stage of recognition on a map with a place index (common/map/place_index.h):
// the few tour locations one query can be at, picked from the whole map at a cost of a few
// operations per location, so the fine stage (S_D * S_N, the likelihood, verification)
// scores those locations' landmarks only (landmark_scope.h).
//
// Candidates come from both kinds of evidence sceneloc fuses: the place_word_top locations
// whose landmarks share most of the query's visual words (tf-idf votes through the inverted
// file, each word match checked by its Hamming signature) and the place_holistic_top locations the
// query looks most like as a whole (the nearest by the approximate holistic distances,
// HolisticShortlist, measured exactly); each with place_expand locations either side, so the
// answer's neighbours, whose landmarks S_N and the confidence read, are scored too. With
// place_distinct (the default) the picks are distinct places: a location already among the
// candidates is passed over for the next best, so neighbouring frames that share the query's words
// do not spend the picks on one stretch of the route.
//
// Thread-safe: a function of its arguments.
#pragma once

#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/localiser.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// Locations the approximate holistic distances shortlist to be measured exactly.
constexpr int kHolisticRefine = 128;

struct PlaceSearch {
  std::vector<int> locations;  // the candidates, ascending
  // Holistic distance (HolisticDistance's scale) to every tour location, exact for the
  // shortlist and approximate elsewhere; empty without holistic descriptors on both sides.
  std::vector<float> holistic;
};

// Whether Localise runs the coarse stage on `map` with `options`: the map has a place index
// and options.use_place_index.
bool UsesPlaceSearch(const Map& map, const MatchOptions& options);

// The candidate locations of `features` (in the map's frame), the word assignment and the
// approximate holistic distances spread over `pool` (may be null). REQUIRES: the map has a
// place index; the query's holistic grid, if any, is the map's.
PlaceSearch SearchPlaces(const FeatureSet& features, const Map& map, const MatchOptions& options,
                         ThreadPool* pool = nullptr);

// Word votes alone (exposed for tests and evaluation): every location's tf-idf similarity to
// the query's words, each of a location's landmarks counted; with hamming_max > 0, a word
// match counts only when the two signatures (place_index.h) differ in at most hamming_max
// of their 64 bits, weighted by how few.
std::vector<float> WordScores(const FeatureSet& features, const Map& map, int hamming_max,
                              ThreadPool* pool = nullptr);

// The holistic distance to every tour location with the location's cells read as their
// codes (place_index.h HolisticCodes), on HolisticDistance's scale: close to it (a cell's
// code errs by a little whatever else the map holds), so the nearest by it hold the nearest
// by the exact distance (on a map padded with 19,689 generated locations, the shortlist of
// 128 held a place within +-2 of the true one for as many Gardens Point night queries as the
// exact distance over the whole map; bench/place_recall). Empty without holistic
// descriptors on both sides. REQUIRES: the query's grid is the map's.
std::vector<float> ApproximateHolisticDistances(const FeatureSet& features, const Map& map,
                                                ThreadPool* pool = nullptr);

// The `count` locations nearest by `approximate`, ascending: those measured exactly.
std::vector<int> HolisticShortlist(const std::vector<float>& approximate, int count);

}  // namespace sceneloc
