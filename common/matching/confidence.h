// The confidence of an answer: the probability that the true location lies within the
// map's tolerance (TrainOptions::tolerance frames) of the answer. Our departure from the
// paper, whose L1 / (L1 + L2) is kept as the "paper" model: neighbouring tour frames share
// most landmarks, so the second best is nearly always the first's neighbour and that ratio
// sits near 0.5 whatever happens.
//
// The calibrated model multiplies two probabilities (docs/results.md measures both):
//   P(within tolerance | the query shows a place of the route): every location's fused
//     evidence s_l (LocationScores, a robust z-scale) read as a posterior over locations,
//     exp(s_l / T) normalised over the tour, summed over the answer's tolerance window.
//     Neighbouring frames share the answer's mass instead of competing with it; a distant
//     look-alike with similar evidence halves it. The answer's own stretch of the route
//     (within tolerance + 1 frames) is read at a flatter temperature, plateau x T:
//     neighbouring tour frames share most of what the query matches, so the differences
//     of their evidence are weaker than those between distinct places, and a query whose
//     evidence rises evenly across a few frames may lie one frame past the tolerance
//     (docs/results.md "The answer's plateau").
//     The verified candidates' evidence depends on the robot's camera through the scale cue
//     (verify_scale_sigma); that posterior is averaged over cameras near the one in use
//     (MatchOptions::confidence_scale_spread; CameraAveragedPosterior in evidence.h, which
//     with CalibratedConfidence there puts the two together).
//   P(the query shows a place of the route): a logistic in how much closer the query's
//     nearest tour image is (smallest holistic distance) than a frame that shows no place
//     of the route comes (the map's calibration, measured at training time from the tour).
// T, the logistic's slope and offset are constants of the method (TrainOptions), the
// off-map level and its spread the map's own.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc {

enum class ConfidenceModel {
  kCalibrated,  // the calibrated probability above (needs a calibrated map)
  kPaper,       // L1 / (L1 + L2) of the two locations with the highest L (eq. 3)
};
const char* ConfidenceModelName(ConfidenceModel model);
StatusOr<ConfidenceModel> ParseConfidenceModel(const std::string& name);

// The model a map supports when `wanted` is asked for: the calibrated model needs a map
// calibration (maps of format version 1 have none) and falls back to the paper's.
ConfidenceModel SupportedModel(const Map& map, ConfidenceModel wanted);

// Locations read at a temperature of their own: (location, temperature) pairs.
using LocationTemperatures = std::vector<std::pair<int, double>>;

// The ratio of a look-alike's verified evidence to the place's own above which the two are
// read as one (the temperature stops rising): a place is never quite its look-alike.
inline constexpr double kMaxLookAlikeRatio = 0.95;

// The answer's look-alikes (Map::lookalike_*): every location within `tolerance` of a
// look-alike b of `answer` with ratio rho, and beyond tolerance + 1 of the answer, at
// temperature / (1 - rho): its evidence counts as if (1 - rho) of its difference from the
// answer's were real. A query of a repeated place verifies against its repeat about as well
// as against itself, so the difference says less than that between distinct places. Empty
// for a map without look-alikes.
LocationTemperatures LookAlikeTemperatures(const Map& map, int answer, double temperature);

// The temperature `own` gives location `l`, 0 if it gives none.
// REQUIRES: `own` ascends by location, one entry each (as LookAlikeTemperatures gives it).
double OwnTemperature(const LocationTemperatures& own, int l);

// P(within tolerance | in the map): the posterior mass of locations within `tolerance`
// of `answer`, with location_scores[l] read as log-likelihoods at `temperature`, or at
// plateau * temperature within tolerance + 1 of `answer` (plateau 1: one temperature), or
// at the temperature `own` gives a location. 0 when there are no scores or all are equal
// (nothing tells any location from another).
// REQUIRES: temperature > 0, plateau >= 1, answer < location_scores.size(), own's
// temperatures > 0 and its locations ascending (OwnTemperature).
double LocationPosterior(const std::vector<float>& location_scores, int answer, int tolerance,
                         double temperature, double plateau, const LocationTemperatures& own = {});

// P(in the map) from the query's smallest holistic distance to the tour; 1 when it is
// unknown (negative: no holistic descriptor) or the map is uncalibrated.
double InMapProbability(const Map& map, double nearest_holistic_distance);
// The same read against one walk's level (map.h Experience::calibration), from the query's
// smallest holistic distance to that walk's images: 1 for an invalid calibration.
double InMapProbability(const Map& map, const Calibration& walk, double nearest_holistic_distance);

// The paper's confidence: L1 / (L1 + L2) over the two highest L; 0 when nothing matched,
// 1 with a single location.
double PaperConfidence(const std::vector<float>& likelihood);

}  // namespace sceneloc
