// Recognition (paper III): features of one frame + a map -> tour locations ranked by
// likelihood, with a confidence and per-stage timings. This is the library call the
// server and sceneloc-eval make.
//
//   S_D  descriptor similarity, pruned at s_min          (descriptor_similarity.h, eq. 1)
//   S_N  neighbourhood similarity with S_A               (neighbourhood.h, eq. 2)
//   S    = S_D * S_N
//   L(l) = sum_{g in G_l} max_f S(f, g) / |G_l|          (eq. 3)
//   candidates: the verify_top best locations by L, and the holistic_top tour images the
//   query looks most like as a whole (holistic_similarity.h; our departure)
//   each candidate verified: epipolar inliers weighted by keypoint-scale agreement
//   (verification.h; our departure, verify_top = holistic_top = 0 turns it off)
//   candidates ranked by their fused evidence (FuseEvidence)
//   confidence: P(the answer is within the map's tolerance), from every location's fused
//   evidence averaged over cameras near the one in use, times P(in the map)
//   (confidence.h, evidence.h CalibratedConfidence); or the paper's L1 / (L1 + L2)
#pragma once

#include <chrono>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/map.h"
#include "common/matching/confidence.h"
#include "common/matching/landmark_scope.h"
#include "common/matching/sequence_options.h"
#include "common/util/status.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

struct MatchOptions {
  // S_min: feature-landmark pairs with S_D below this are dropped (paper: 0.3).
  double s_min = 0.3;
  // Use S = S_D * S_N (paper). false scores with S_D alone (ablation).
  bool use_neighbourhood = true;
  // Eq. 2 as printed sums its denominator from n = 0, i.e. includes the centre landmark's
  // own weight p(g|g) = 1. true follows the printed equation.
  bool include_centre_term = true;
  // Walk at most this many neighbours of each landmark (0 = all the map stores).
  int max_neighbours = 0;
  // Keep at most this many query features per landmark, the best by S_D (0 = all): a
  // work budget that bounds S_N's cost whatever a query holds (8,192 copies of one
  // descriptor took a minute of CPU without it). 32 changes no answer on the development
  // sets (16 changed a few, within noise, and one confidence).
  int max_matches_per_landmark = 32;
  // Weight each pair by p(g|f) = S_D(f,g) / sum_k S_D(f,g_k), the posterior of eq. 4:
  // a feature resembling many landmarks spreads its vote thin (what the ratio test does
  // for the baseline). false follows the paper's eq. 3.
  bool distinctiveness = false;
  // L(l) = sum_{g in G_l} max_f S(f,g) / |G_l|^alpha. alpha = 1 is eq. 3; smaller values
  // stop images with few landmarks from winning on a handful of chance matches.
  double size_exponent = 1.0;
  // Re-rank this many best locations by geometric verification (verification.h): by the
  // number of epipolar inliers between the query and the landmarks' positions in each
  // candidate, ties broken by L. 0 ranks by L alone (paper). Default by measurement.
  int verify_top = 10;
  // Use the holistic evidence (holistic_similarity.h; our departure): its candidates and its
  // z-score in the fusion. No effect on maps or queries without holistic descriptors.
  bool use_holistic = true;
  // Also verify this many tour images with the smallest holistic distance (0 = none).
  int holistic_top = 10;
  // RANSAC inlier threshold for that verification, as a fraction of the map frame's long
  // side (0.00625 = 3 px at 480).
  double verify_ransac_threshold = 0.00625;
  // RANSAC iterations per verified candidate at most (its cost grows linearly with this).
  int verify_ransac_iterations = 200;
  // The fundamental-matrix search (VerifyEstimator in verification.h): "usac" (RANSAC with
  // SPRT, the default) or "ransac" (OpenCV's classic FM_RANSAC).
  std::string verify_estimator = "usac";
  // Orientation check of verification (verification.h): correspondences whose keypoint
  // orientations differ by more than this many degrees are dropped (0 = none).
  double verify_angle_tolerance = 30;
  // Scale agreement: a verified candidate's inlier count is weighted by
  // exp(-m^2 / (2 s^2)), m the median log ratio of query to tour keypoint size over its
  // inliers, s this setting (e.g. 0.2 ~ sizes within about 20%). 0 turns it off. Wide
  // enough for a robot camera that is not the tour's (another focal length scales every
  // size alike); 0.15 lost much on such cameras (docs/results.md, "Other cameras").
  double verify_scale_sigma = 0.25;
  // Not a setting: log(robot camera's size / tour camera's) of one thing seen from the same
  // place, i.e. the two focal lengths' ratio in the map's frame. The scale cue measures
  // agreement from it instead of from 0. A request may state it (LocaliseRequest.
  // camera_scale) and a session learns it (sequence_filter.h); else, unless camera_known,
  // Localise takes the one the frame's shape implies (FrameCamera: the tour's camera, 0, for
  // a frame of the tour frame's shape).
  double camera_log_scale = 0;
  // Not a setting: camera_log_scale is known (stated by the client, learnt by a session)
  // rather than assumed from the frame.
  bool camera_known = false;
  // Not a setting: how far the camera in use may be off beyond confidence_scale_spread (one
  // standard deviation; the confidence averages over both, in quadrature). FrameCamera's.
  double camera_log_doubt = 0;
  // Fusion of the evidence (FuseEvidence in localiser.cc): a candidate's score is its
  // holistic z-score plus verify_weight for every scale-weighted inlier above
  // verify_chance_inliers, the count a wrong candidate reaches by chance. Without holistic
  // evidence the scale-weighted inliers alone rank.
  double verify_chance_inliers = 8;
  double verify_weight = 0.2;
  // The confidence model ("calibrated" or "paper"); a map without calibration (format
  // version 1) always answers with "paper".
  std::string confidence_model = "calibrated";
  // The calibrated confidence reads the answer's own stretch of the route (within the map's
  // tolerance + 1 frames) at this multiple of the map's temperature (confidence.h; 1 = one
  // temperature everywhere). Measured: docs/results.md "The answer's plateau".
  double confidence_plateau = 2;
  // The scale cue (verify_scale_sigma) tells a frame from the ones a few metres before and
  // after it by how large things look to the robot's camera, which is known only so well:
  // the calibrated confidence averages the answer's posterior over cameras whose log scale
  // lies within this spread (one standard deviation) of the one in use (camera_log_scale),
  // so an answer that holds only for exactly that camera is not certain. 0 = the camera in
  // use alone. Measured: docs/results.md "The confidence over cameras".
  double confidence_scale_spread = 0.1;
  // Answers with a confidence below this are UNKNOWN (in [0, 1]; 0 = always LOCALISED).
  // Measured: 0.8 accepts 88% of the correct Gardens Point day answers and none of the
  // out-of-map frames of the development sets (docs/results.md).
  double min_confidence = 0.8;
  // How many ranked locations a result carries.
  int top_k = 5;
  // The coarse stage (place_search.h) on maps with a place index: the fine stage scores
  // only the locations it picks, place_word_top by shared visual words and
  // place_holistic_top by approximate holistic distance, each with place_expand locations
  // either side. false scores every location of every map (the paper). Measured:
  // docs/results.md "Maps that grow" and "Distinct places" (on a 20,000-location map words
  // find the right place more often than the holistic distance: 28 + 4 picks score about as
  // many locations as 24 + 24 did before picks were distinct, and find the place more often).
  bool use_place_index = true;
  int place_word_top = 28;
  // A word match between a query feature and a landmark counts only when their signatures
  // (a Hamming embedding, place_index.h) differ in at most this many of 64 bits; 0 = every
  // word match counts (plain tf-idf). Measured: docs/history.md "Maps that grow".
  int place_hamming_max = 32;
  int place_holistic_top = 4;
  int place_expand = 3;
  // Picks are distinct places: a location already among the candidates (within
  // place_expand of an earlier pick, by words or by holistic distance) is passed over for
  // the next best, so each pick brings a stretch of the route not yet scored. false: the
  // best place_word_top and place_holistic_top, however close together. Measured:
  // docs/results.md "Distinct places".
  bool place_distinct = true;
  // The filter of requests that name a session (sequence_filter.h).
  SequenceOptions sequence;
  // Not a setting: when the call must finish (the server sets it from the request's
  // arrival and limits.max_request_ms). Checked between stages; past it, Localise returns
  // DeadlineExceeded naming the stage and the time each stage took.
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();

  // The ranges and choices of MatchSettings.
  Status Validate() const;
};

// The robot camera a frame of `width` x `height` pixels implies when nobody states it, on the
// scale of MatchOptions::camera_log_scale (which relates focal lengths over image width): the
// tour's (0, no doubt) for a frame of the tour frame's shape. A frame of another shape (a 4:3
// sensor against a 16:9 tour) may share the tour camera's horizontal field of view (0) or its
// vertical one (log of the tour frame's aspect ratio over the frame's: a 4:3 crop of a 16:9
// view looks 4/3 larger once brought to the map's width), or neither, and one frame does not
// say which: halfway between (within the scales a request may state), doubted by half the
// distance. Shapes within 2% count as equal (rounding of a resized frame).
struct FrameCameraGuess {
  double log_scale = 0;
  double doubt = 0;
};
FrameCameraGuess FrameCamera(int width, int height, const Map& map);

// The camera scales a request may state (LocaliseRequest.camera_scale): a focal length a
// quarter or four times the tour camera's, relative to image width.
inline constexpr double kMinCameraScale = 0.25;
inline constexpr double kMaxCameraScale = 4.0;
// "[0.25, 4]": the range, as messages and help name it.
std::string CameraScaleRange();
// InvalidArgument naming the range unless `scale` is in [kMinCameraScale, kMaxCameraScale].
Status CheckCameraScale(double scale);

// The matching settings file's fields (configs/match.yaml), bound to `o`: matching: and
// sequence: (match_settings.cc).
SettingTable MatchSettings(MatchOptions* o);

struct RankedLocation {
  int index = 0;           // place (Map::PlaceOf; the tour image in a map of one walk)
  std::string image_name;  // the place's name (its first tour image's file name)
  float likelihood = 0;    // L(l)
  int inliers = -1;        // epipolar inliers when verified, else -1
  float log_scale = 0;     // median log(query / tour keypoint size) of the inliers
};

struct StageTimings {
  double place_ms = 0;          // the coarse stage (place_search.h); 0 without it
  double descriptor_ms = 0;     // S_D over all pairs
  double neighbourhood_ms = 0;  // S_N over the surviving pairs
  double likelihood_ms = 0;     // L(l) and ranking
  double holistic_ms = 0;       // holistic distances to every tour image
  double verify_ms = 0;         // geometric verification of the best candidates
  double total_ms = 0;
};

// Everything known about one verified candidate location.
struct CandidateEvidence {
  // The place (Map::PlaceOf): what answers and the confidence count in. Before places are
  // pooled (Localise's last step) the tour image, as in a map of one walk.
  int location = 0;
  int image = -1;          // the tour image verified (one of the place's experiences)
  float likelihood = 0;    // L(l), eq. 3
  float holistic = -1;     // holistic distance to tour image l; -1 without descriptors
  int holistic_rank = -1;  // its rank among all tour images by that distance (0 = best)
  // How far below the typical distance it lies: (median - d) / (1.4826 MAD) over all tour
  // images, a robust z-score; 0 without descriptors.
  float holistic_z = 0;
  int correspondences = 0;  // query features matched to landmarks seen in l
  int inliers = 0;          // of those, epipolar inliers
  float log_scale = 0;      // median log(query / tour keypoint size) of the inliers
  double score = 0;         // the fused evidence the candidates are ranked by
};

// Whether an answer is one to act on.
enum class Decision {
  kLocalised,  // confidence >= min_confidence
  kUnknown,    // below it: perhaps a place not on the route; the ranking is still there
};
const char* DecisionName(Decision decision);

struct LocaliseResult {
  std::vector<RankedLocation> ranked;  // best first, at most top_k
  // The probability that the best answer lies within the map's tolerance of the truth
  // (confidence.h), or the paper's L1 / (L1 + L2) when that is the model in use.
  float confidence = 0;
  ConfidenceModel confidence_model = ConfidenceModel::kCalibrated;  // the model used
  Decision decision = Decision::kUnknown;
  // The query's smallest holistic distance to any tour image; -1 without holistic evidence.
  float nearest_holistic_distance = -1;
  size_t descriptor_matches = 0;  // pairs with S_D >= s_min
  StageTimings timings;
  // The verified candidates, best first (the evidence behind the answer).
  std::vector<CandidateEvidence> candidates;
  // Every place's evidence on the fused scale (LocationScores in evidence.h): the
  // candidates' fused scores, the others' holistic z-score (of its best image).
  std::vector<float> location_scores;
  // The camera the evidence was read with (MatchOptions::camera_log_scale, camera_log_doubt):
  // the caller's when known, else the frame's (FrameCamera).
  double camera_log_scale = 0;
  double camera_log_doubt = 0;
};

// Localises one frame, with options.camera_log_scale when options.camera_known, else with the
// camera the frame's shape implies (FrameCamera). `pool` may be null (runs on the caller).
// Thread-safe: any number of calls may share one map and one pool. REQUIRES: map is Validate()d and
// Finalize()d.
StatusOr<LocaliseResult> Localise(const FeatureSet& features, const Map& map,
                                  const MatchOptions& options, ThreadPool* pool);

// Reads `result` (Localise's, with any camera) again with options.camera_log_scale (and its
// camera_log_doubt; camera_known is not read): its
// verified candidates' fused scores, their entries of location_scores, the ranking, the
// confidence and the decision, as Localise with that camera would have answered (nothing
// else depends on the camera). Takes min_confidence, top_k (at most the result's),
// confidence_plateau, confidence_scale_spread and the fusion settings from `options`; the
// confidence model is the result's (the paper's reads L alone and is kept). The server
// reads a session's frame with the session's camera this way (server/request_handler.cc).
// REQUIRES: result from Localise on `map` with `options` but for the camera and the
// settings named above.
void ReadWithCamera(const Map& map, const MatchOptions& options, LocaliseResult* result);

// Per-landmark and per-location scores of one frame.
struct FrameScores {
  std::vector<float> likelihood;      // L(l) per tour location (0 outside the scope)
  std::vector<float> best_score;      // max_f S(f, g) per landmark, by scope position
  std::vector<int32_t> best_feature;  // its argmax, -1 when g matched nothing
};

// Scores the locations of `scope` (exposed for evaluation and tests); fills the descriptor
// match count and stage timings of `stats`.
StatusOr<FrameScores> ScoreLocations(const FeatureSet& features, const Map& map,
                                     const LandmarkScope& scope, const MatchOptions& options,
                                     ThreadPool* pool, LocaliseResult* stats);

// ScoreLocations over every location of the map.
StatusOr<FrameScores> ScoreLocations(const FeatureSet& features, const Map& map,
                                     const MatchOptions& options, ThreadPool* pool,
                                     LocaliseResult* stats);

}  // namespace sceneloc
