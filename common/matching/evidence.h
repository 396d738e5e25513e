// The evidence for each candidate location and how it is fused into one score (our
// departure from the paper; measured in docs/results.md). Localise (localiser.h) selects
// candidates here, verifies them, then ranks them by FuseEvidence.
#pragma once

#include <vector>

#include "common/matching/confidence.h"
#include "common/matching/localiser.h"

namespace sceneloc {

// Robust z-scores of distances: (median - d) / (1.4826 MAD) per entry, so a location far
// below the typical distance scores high. Empty in, empty out.
std::vector<float> RobustZ(const std::vector<float>& distance);

// The same with the median and MAD taken from `reference` (a sample of the distances, e.g.
// of evenly spaced locations on a map too big to measure every one exactly).
std::vector<float> RobustZ(const std::vector<float>& distance, const std::vector<float>& reference);

// The locations to verify: the verify_top best by L (by_likelihood is every location by
// descending L), then the holistic_top best by holistic distance that are not already in,
// each once, in that order, with their L and holistic evidence filled in. `holistic` and
// `holistic_z` are empty without holistic evidence.
std::vector<CandidateEvidence> SelectCandidates(const std::vector<int>& by_likelihood,
                                                const std::vector<float>& likelihood,
                                                const std::vector<float>& holistic,
                                                const std::vector<float>& holistic_z,
                                                const MatchOptions& options);

// Geometric evidence of a verified candidate: its epipolar inliers weighted by keypoint
// scale agreement, exp(-m^2 / 2 s^2) with s = verify_scale_sigma (1 when 0) and m the
// candidate's log_scale less the camera's (MatchOptions::camera_log_scale).
double VerifiedScore(const CandidateEvidence& c, const MatchOptions& options);

// The score candidates are ranked by: the holistic z-score plus verify_weight for every
// verified inlier above verify_chance_inliers. Without holistic evidence, VerifiedScore.
double FuseEvidence(const CandidateEvidence& c, const MatchOptions& options);

// Every location's evidence on one scale, the confidence's: a candidate's holistic z-score
// plus verify_weight per verified inlier above chance (its geometric evidence alone without
// holistic evidence); any other location's holistic z-score (its geometric evidence
// unmeasured, taken as chance), or 0 without holistic evidence.
std::vector<float> LocationScores(const std::vector<CandidateEvidence>& candidates,
                                  const std::vector<float>& holistic_z, size_t num_locations,
                                  const MatchOptions& options);

// The candidates' entries of LocationScores, written into `scores` (every other entry left
// as it is): how a session re-reads a frame's evidence for its camera (sequence_filter.h).
// Candidates past the end of `scores` are skipped.
void ScoreCandidates(const std::vector<CandidateEvidence>& candidates, const MatchOptions& options,
                     std::vector<float>* scores);

// P(within tolerance | in the map) averaged over the robot's camera (our departure): the
// answer's LocationPosterior (confidence.h) with the candidates scored for each camera whose
// log scale lies within +-2 spreads of options.camera_log_scale, weighted by a normal of
// the spread (confidence_scale_spread and camera_log_doubt in quadrature); the other locations'
// scores do not depend on the camera. The answer stays the one ranked with camera_log_scale.
// LocationPosterior of `location_scores` itself when confidence_scale_spread or verify_scale_sigma
// is 0 (no scale cue to doubt) or nothing was verified. `own`: locations read at their own
// temperature, as LocationPosterior's. O(locations + (candidates + own) x 9).
double CameraAveragedPosterior(const std::vector<float>& location_scores,
                               const std::vector<CandidateEvidence>& candidates, int answer,
                               int tolerance, double temperature, const MatchOptions& options,
                               const LocationTemperatures& own = {});

// The calibrated confidence (confidence.h): CameraAveragedPosterior with the map's tolerance
// and temperature, the answer's look-alikes at theirs (LookAlikeTemperatures), times
// InMapProbability.
double CalibratedConfidence(const Map& map, const std::vector<float>& location_scores,
                            const std::vector<CandidateEvidence>& candidates, int answer,
                            double nearest_holistic_distance, const MatchOptions& options);

}  // namespace sceneloc
