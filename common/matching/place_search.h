// The coarse stage of recognition on a map with a place index (common/map/place_index.h):
// the few tour locations one query can be at, picked from the whole map at a cost of a few
// operations per location, so the fine stage (S_D * S_N, the likelihood, verification)
// scores those locations' landmarks only (landmark_scope.h).
//
// Candidates come from both kinds of evidence sceneloc fuses: the place_word_top locations
// whose landmarks share most of the query's visual words (tf-idf votes through the inverted
// file, each word match checked by its Hamming signature) and the place_holistic_top locations the
// query looks most like as a whole (the shortlist of the approximate holistic distances,
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

// Locations each approximate holistic ranking shortlists to be measured exactly.
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

// The holistic distance to every tour location through the map's principal axes
// (place_index.h HolisticProjection), at the lateral shift nearest within them:
struct ApproximateHolistic {
  // Within the axes alone.
  std::vector<float> nearness;
  // With the parts the axes leave out added as if orthogonal: HolisticDistance's scale, read
  // as the distance of the locations not measured exactly.
  std::vector<float> distance;
};
// Both empty without holistic descriptors on both sides.
ApproximateHolistic ApproximateHolisticDistances(const FeatureSet& features, const Map& map,
                                                 ThreadPool* pool = nullptr);

// The locations to measure exactly: the `count` nearest by either approximation, ascending.
// Each ranks well where the other fails. With the residuals, on a map of one route whose
// axes describe it (what the axes leave out is part of the difference between places);
// without, on a map that is mostly something else (the axes fitted on the other route miss
// much of this route's images, and the residuals' size then says how much they miss, not
// how near an image is: on a map padded with 19,689 generated locations, the shortlist by
// distance held a place within +-2 of Gardens Point day_right queries' truth for 62 of 100
// at 4 picks, by nearness for 95; bench/place_recall).
std::vector<int> HolisticShortlist(const ApproximateHolistic& approximate, int count);

}  // namespace sceneloc
