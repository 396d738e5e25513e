#include "common/matching/localiser.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numeric>

#include "common/matching/descriptor_similarity.h"
#include "common/matching/evidence.h"
#include "common/matching/holistic_similarity.h"
#include "common/matching/neighbourhood.h"
#include "common/matching/place_search.h"
#include "common/matching/verification.h"
#include "common/matching/walks.h"
#include "common/util/timer.h"

namespace sceneloc {

const char* DecisionName(Decision decision) {
  return decision == Decision::kLocalised ? "LOCALISED" : "UNKNOWN";
}

namespace {

// DeadlineExceeded once `deadline` has passed, naming the stage just finished and what each
// stage so far took.
Status CheckDeadline(const MatchOptions& options, const char* after, const StageTimings& t) {
  if (std::chrono::steady_clock::now() <= options.deadline) return Status::Ok();
  char spent[200];
  std::snprintf(spent, sizeof(spent),
                "descriptor %.1f ms, neighbourhood %.1f ms, likelihood %.1f ms, holistic %.1f ms, "
                "verification %.1f ms",
                t.descriptor_ms, t.neighbourhood_ms, t.likelihood_ms, t.holistic_ms, t.verify_ms);
  return DeadlineExceeded(std::string("matching passed its deadline after the ") + after +
                          " stage (" + spent + ")");
}

}  // namespace

std::string CameraScaleRange() {
  char range[64];
  std::snprintf(range, sizeof(range), "[%g, %g]", kMinCameraScale, kMaxCameraScale);
  return range;
}

Status CheckCameraScale(double scale) {
  if (scale >= kMinCameraScale && scale <= kMaxCameraScale) return Status::Ok();
  return InvalidArgument("camera_scale must be in " + CameraScaleRange() +
                         " (the robot camera's focal length over image width, against the "
                         "tour camera's), got " +
                         std::to_string(scale));
}

StatusOr<FrameScores> ScoreLocations(const FeatureSet& features, const Map& map,
                                     const MatchOptions& options, ThreadPool* pool,
                                     LocaliseResult* stats) {
  return ScoreLocations(features, map, LandmarkScope::Whole(map), options, pool, stats);
}

StatusOr<FrameScores> ScoreLocations(const FeatureSet& features, const Map& map,
                                     const LandmarkScope& scope, const MatchOptions& options,
                                     ThreadPool* pool, LocaliseResult* stats) {
  SCENELOC_RETURN_IF_ERROR(options.Validate());
  SCENELOC_RETURN_IF_ERROR(ValidateFeatureSet(features));
  Stopwatch watch;
  const std::vector<DescriptorMatch> matches =
      ComputeDescriptorMatches(features, map, scope, static_cast<float>(options.s_min), pool,
                               options.max_matches_per_landmark);
  stats->descriptor_matches = matches.size();
  stats->timings.descriptor_ms = watch.Milliseconds();
  SCENELOC_RETURN_IF_ERROR(CheckDeadline(options, "descriptor", stats->timings));

  watch.Reset();
  std::vector<float> neighbourhood;
  if (options.use_neighbourhood) {
    neighbourhood = NeighbourhoodSimilarities(
        features, map, scope, matches, options.include_centre_term, options.max_neighbours, pool);
  }
  stats->timings.neighbourhood_ms = watch.Milliseconds();
  SCENELOC_RETURN_IF_ERROR(CheckDeadline(options, "neighbourhood", stats->timings));

  watch.Reset();
  // Each feature's total similarity mass, the denominator of p(g|f).
  std::vector<float> mass;
  if (options.distinctiveness) {
    mass.assign(static_cast<size_t>(features.size()), 0.0f);
    for (const DescriptorMatch& m : matches) mass[m.feature] += m.similarity;
  }
  // max_f S(f, g) per landmark (by scope position), then eq. 3.
  FrameScores scores;
  std::vector<float>& best = scores.best_score;
  best.assign(scope.size(), 0.0f);
  scores.best_feature.assign(best.size(), -1);
  for (size_t k = 0; k < matches.size(); ++k) {
    const DescriptorMatch& m = matches[k];
    float s = m.similarity * (options.use_neighbourhood ? neighbourhood[k] : 1.0f);
    if (options.distinctiveness) s *= m.similarity / mass[m.feature];
    if (s > best[m.landmark]) {
      best[m.landmark] = s;
      scores.best_feature[m.landmark] = static_cast<int32_t>(m.feature);
    }
  }
  std::vector<float>& likelihood = scores.likelihood;
  likelihood.assign(static_cast<size_t>(map.num_images()), 0.0f);
  for (int l : scope.locations()) {
    const uint32_t begin = map.image_offsets[l], end = map.image_offsets[l + 1];
    if (begin == end) continue;
    double sum = 0;
    for (uint32_t k = begin; k < end; ++k) {
      const int32_t p = scope.Position(map.image_landmarks[k]);
      if (p >= 0) sum += best[static_cast<size_t>(p)];
    }
    likelihood[static_cast<size_t>(l)] =
        static_cast<float>(sum / std::pow(static_cast<double>(end - begin), options.size_exponent));
  }
  stats->timings.likelihood_ms = watch.Milliseconds();
  return scores;
}

namespace {

// The `count` locations of highest `value`, best first (lowest index first on ties): the
// head of a stable sort by descending value, without sorting a big map's every location.
std::vector<int> RankByValue(const std::vector<float>& value, size_t count) {
  std::vector<int> order(value.size());
  std::iota(order.begin(), order.end(), 0);
  const auto head = order.begin() + static_cast<std::ptrdiff_t>(std::min(count, order.size()));
  std::partial_sort(order.begin(), head, order.end(), [&](int a, int b) {
    return value[a] > value[b] || (value[a] == value[b] && a < b);
  });
  order.erase(head, order.end());
  return order;
}

// Ranks the scored candidates best first (fused score, L breaking ties) ahead of `rest` (the
// other locations by descending L, at least top_k of them when there are), fills
// location_scores' candidate entries, the ranked list, and the confidence of the best with
// the model the map supports (`paper`: the paper's, which reads L alone) and the decision it
// implies.
void RankAndAssess(const Map& map, const MatchOptions& options,
                   const std::vector<RankedLocation>& rest, double paper, LocaliseResult* result) {
  result->camera_log_scale = options.camera_log_scale;
  result->camera_log_doubt = options.camera_log_doubt;
  std::vector<CandidateEvidence>& candidates = result->candidates;
  for (CandidateEvidence& c : candidates) c.score = FuseEvidence(c, options);
  ScoreCandidates(candidates, options, &result->location_scores);
  // Exact ties of both go to the earlier candidate as selected (by L, then holistic rank):
  // kept by ReadWithCamera, which sorts the candidates in that order first.
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const CandidateEvidence& a, const CandidateEvidence& b) {
                     return a.score > b.score ||
                            (a.score == b.score && a.likelihood > b.likelihood);
                   });
  result->ranked.clear();
  const size_t k = static_cast<size_t>(std::max(1, options.top_k));
  for (size_t i = 0; i < candidates.size() && result->ranked.size() < k; ++i) {
    const CandidateEvidence& c = candidates[i];
    result->ranked.push_back(
        {c.location, map.PlaceName(c.location), c.likelihood, c.inliers, c.log_scale});
  }
  for (size_t i = 0; i < rest.size() && result->ranked.size() < k; ++i) {
    result->ranked.push_back(rest[i]);
  }
  const ConfidenceModel wanted =
      options.confidence_model == "paper" ? ConfidenceModel::kPaper : ConfidenceModel::kCalibrated;
  result->confidence_model = SupportedModel(map, wanted);
  if (result->ranked.empty()) return;
  result->confidence = static_cast<float>(
      result->confidence_model == ConfidenceModel::kPaper
          ? paper
          : CalibratedConfidence(map, result->location_scores, candidates, result->ranked[0].index,
                                 result->nearest_holistic_distance, options));
  result->decision =
      result->confidence >= options.min_confidence ? Decision::kLocalised : Decision::kUnknown;
}

// Verifies every candidate (one RANSAC each, spread over the pool).
void VerifyCandidates(const FeatureSet& features, const Map& map, const LandmarkScope& scope,
                      const FrameScores& scores, const MatchOptions& options, ThreadPool* pool,
                      std::vector<CandidateEvidence>* candidates) {
  VerifyOptions verify_options;
  verify_options.ransac_threshold_px = options.verify_ransac_threshold * map.frame_long_side();
  verify_options.max_iterations = options.verify_ransac_iterations;
  verify_options.angle_tolerance_deg = options.verify_angle_tolerance;
  verify_options.estimator =
      options.verify_estimator == "ransac" ? VerifyEstimator::kRansac : VerifyEstimator::kUsac;
  auto verify = [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      CandidateEvidence& c = (*candidates)[i];
      const Verification v = VerifyCandidate(features, map, c.location, scope, scores.best_score,
                                             scores.best_feature, verify_options);
      c.correspondences = v.correspondences;
      c.inliers = v.inliers;
      c.log_scale = v.log_scale;
    }
  };
  if (pool != nullptr) {
    pool->ParallelFor(candidates->size(), 1, verify);
  } else {
    verify(0, candidates->size());
  }
}

// Brings a feature set extracted in another frame width into the map's: keypoint positions
// and sizes scale uniformly (descriptors are scale-invariant).
FeatureSet ScaledToMapFrame(const FeatureSet& features, const Map& map) {
  FeatureSet scaled = features;
  const float s = static_cast<float>(map.image_width) / static_cast<float>(features.image_width);
  for (Keypoint& k : scaled.keypoints) {
    k.x *= s;
    k.y *= s;
    k.size *= s;
  }
  scaled.image_width = map.image_width;
  scaled.image_height = std::max(1, static_cast<int>(std::lround(features.image_height * s)));
  return scaled;
}

struct QueryHolistic {
  std::vector<float> distance;  // to every location; empty without holistic evidence
  std::vector<float> z;         // RobustZ of it
};

// The holistic evidence of the query: exact for the whole map; with the coarse stage, exact
// over the scope (and the shortlist it measured) and approximate elsewhere. The z-scores are
// read against the locations the query is scored against, the whole map or the scope: the
// fine stage then sees the query among a few hundred locations, as on the maps the
// confidence was calibrated on, whatever the map's size. (Against an even sample of a big
// map, its typical place, the places a query resembles all stand out and the confidence
// rises with the map: docs/history.md "Maps that grow".)
QueryHolistic MeasureHolistic(const FeatureSet& features, const Map& map,
                              const LandmarkScope& scope, const PlaceSearch* search,
                              ThreadPool* pool) {
  QueryHolistic h;
  const int max_shift = map.options.extractor.holistic.max_shift;
  if (search == nullptr) {
    h.distance = HolisticDistances(features, map, max_shift, pool);
    h.z = WalkZ(map, h.distance, nullptr);
    WeighByWalk(map, h.distance, &h.z);
    return h;
  }
  if (search->holistic.empty()) return h;
  h.distance = search->holistic;
  const std::vector<int>& exact = scope.locations();
  const std::vector<float> measured = HolisticDistancesTo(features, map, exact, max_shift, pool);
  for (size_t i = 0; i < exact.size(); ++i) h.distance[exact[i]] = measured[i];
  h.z = WalkZ(map, h.distance, &exact);
  WeighByWalk(map, h.distance, &h.z);
  return h;
}

StatusOr<LocaliseResult> LocaliseInFrame(const FeatureSet& features, const Map& map,
                                         const MatchOptions& options, ThreadPool* pool) {
  Stopwatch total;
  LocaliseResult result;
  const bool coarse = UsesPlaceSearch(map, options);
  PlaceSearch search;
  if (coarse) search = SearchPlaces(features, map, options, pool);
  const LandmarkScope scope =
      coarse ? LandmarkScope::Of(map, search.locations) : LandmarkScope::Whole(map);
  result.timings.place_ms = total.Milliseconds();
  SCENELOC_ASSIGN_OR_RETURN(const FrameScores scores,
                            ScoreLocations(features, map, scope, options, pool, &result));
  const std::vector<float>& likelihood = scores.likelihood;
  Stopwatch stage;
  const QueryHolistic measured =
      options.use_holistic ? MeasureHolistic(features, map, scope, coarse ? &search : nullptr, pool)
                           : QueryHolistic();
  const std::vector<float>& holistic = measured.distance;
  const std::vector<float>& holistic_z = measured.z;
  result.timings.holistic_ms = stage.Milliseconds();
  SCENELOC_RETURN_IF_ERROR(CheckDeadline(options, "holistic", result.timings));

  stage.Reset();
  // As many by L as the candidates and a ranked list could need.
  const std::vector<int> by_likelihood = RankByValue(
      likelihood, static_cast<size_t>(options.verify_top + options.holistic_top + options.top_k));
  // Candidates by holistic distance come from the scope: elsewhere it is approximate.
  std::vector<float> selectable = holistic;
  if (coarse && !selectable.empty()) {
    std::vector<float> outside(selectable.size(), std::numeric_limits<float>::max());
    for (int l : scope.locations()) outside[l] = selectable[l];
    selectable = std::move(outside);
  }
  std::vector<CandidateEvidence> candidates =
      SelectCandidates(by_likelihood, likelihood, selectable, holistic_z, options);
  for (CandidateEvidence& c : candidates) {
    if (!holistic.empty()) c.holistic = holistic[c.location];
  }
  result.timings.likelihood_ms += stage.Milliseconds();

  stage.Reset();
  VerifyCandidates(features, map, scope, scores, options, pool, &candidates);
  if (!holistic.empty()) {
    result.nearest_holistic_distance = *std::min_element(selectable.begin(), selectable.end());
  }
  PoolPlaces(map, options, &candidates);
  result.location_scores =
      LocationScores(candidates, PlaceMaxima(map, holistic_z), map.num_places(), options);
  // The places not verified, by L: as many as a ranked list could need.
  std::vector<bool> listed(static_cast<size_t>(map.num_places()), false);
  for (const CandidateEvidence& c : candidates) listed[c.location] = true;
  std::vector<RankedLocation> rest;
  for (size_t i = 0; i < by_likelihood.size() && rest.size() < static_cast<size_t>(options.top_k);
       ++i) {
    const int l = by_likelihood[i], place = map.PlaceOf(l);
    if (listed[place]) continue;
    listed[place] = true;
    rest.push_back({place, map.PlaceName(place), likelihood[l], -1, 0.0f});
  }
  result.timings.verify_ms = stage.Milliseconds();
  result.candidates = std::move(candidates);
  RankAndAssess(map, options, rest, PaperConfidence(likelihood), &result);
  result.timings.total_ms = total.Milliseconds();
  return result;
}

}  // namespace

FrameCameraGuess FrameCamera(int width, int height, const Map& map) {
  if (width <= 0 || height <= 0 || map.image_width <= 0 || map.image_height <= 0) return {};
  // log(tour aspect / frame aspect): the vertical field of view's camera.
  const double vertical = std::log(static_cast<double>(map.image_width) * height /
                                   (static_cast<double>(map.image_height) * width));
  if (std::abs(vertical) < 0.02) return {};
  // Within the scales a request may state (a frame of an extreme shape is not a camera).
  const double halfway =
      std::clamp(vertical / 2, std::log(kMinCameraScale), std::log(kMaxCameraScale));
  return {halfway, std::abs(vertical) / 2};
}

StatusOr<LocaliseResult> Localise(const FeatureSet& features, const Map& map,
                                  const MatchOptions& given, ThreadPool* pool) {
  SCENELOC_RETURN_IF_ERROR(ValidateFeatureSet(features));
  MatchOptions options = given;
  if (!options.camera_known) {
    const FrameCameraGuess guess = FrameCamera(features.image_width, features.image_height, map);
    options.camera_log_scale = guess.log_scale;
    options.camera_log_doubt = guess.doubt;
  }
  if (!features.holistic.empty() && map.has_holistic() &&
      features.holistic_grid != map.holistic_grid) {
    const HolisticGrid& q = features.holistic_grid;
    const HolisticGrid& m = map.holistic_grid;
    return InvalidArgument("the feature set's holistic descriptor is on a " +
                           std::to_string(q.cols) + "x" + std::to_string(q.rows) + "x" +
                           std::to_string(q.bins) + " grid, the map's on " +
                           std::to_string(m.cols) + "x" + std::to_string(m.rows) + "x" +
                           std::to_string(m.bins) + ": extract with the map's settings");
  }
  if (features.image_width == map.image_width) {
    return LocaliseInFrame(features, map, options, pool);
  }
  return LocaliseInFrame(ScaledToMapFrame(features, map), map, options, pool);
}

void ReadWithCamera(const Map& map, const MatchOptions& options, LocaliseResult* result) {
  const int places = map.num_places();
  std::vector<bool> verified(static_cast<size_t>(places), false);
  for (const CandidateEvidence& c : result->candidates) {
    if (c.location >= 0 && c.location < places) verified[c.location] = true;
  }
  std::vector<RankedLocation> rest;
  for (const RankedLocation& r : result->ranked) {
    if (r.index < 0 || r.index >= places || !verified[r.index]) rest.push_back(r);
  }
  // The candidates in the order SelectCandidates chose them, which breaks exact ties: the
  // verify_top best by L (lower location first on equal L, as RankByValue), then the others
  // by holistic rank.
  std::vector<CandidateEvidence>& candidates = result->candidates;
  std::sort(candidates.begin(), candidates.end(),
            [](const CandidateEvidence& a, const CandidateEvidence& b) {
              return a.likelihood > b.likelihood ||
                     (a.likelihood == b.likelihood && a.location < b.location);
            });
  const auto by_l =
      candidates.begin() + std::min<ptrdiff_t>(std::max(0, options.verify_top),
                                               static_cast<ptrdiff_t>(candidates.size()));
  std::sort(by_l, candidates.end(), [](const CandidateEvidence& a, const CandidateEvidence& b) {
    return a.holistic_rank < b.holistic_rank;
  });
  // The paper's confidence reads L alone: a result scored with it keeps it.
  MatchOptions read = options;
  read.confidence_model = ConfidenceModelName(result->confidence_model);
  RankAndAssess(map, read, rest, result->confidence, result);
}

}  // namespace sceneloc
