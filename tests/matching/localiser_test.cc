#include "common/matching/localiser.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>

#include "common/matching/descriptor_similarity.h"
#include "common/matching/neighbourhood.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// The features of tour image `l` as the map saw them: its landmarks' means at their
// observed positions, plus a few random features.
FeatureSet FeaturesOfImage(const Map& map, int l, uint32_t seed) {
  FeatureSet f;
  f.image_width = map.image_width;
  f.image_height = map.image_height;
  std::vector<int> rows;
  for (uint32_t k = map.image_offsets[l]; k < map.image_offsets[l + 1]; ++k) {
    const uint32_t g = map.image_landmarks[k];
    for (uint32_t o = map.observation_offsets[g]; o < map.observation_offsets[g + 1]; ++o) {
      if (map.observation_image[o] != static_cast<uint32_t>(l)) continue;
      f.keypoints.push_back(
          {map.ObservationX(o), map.ObservationY(o), map.ObservationSize(o), 0, 1, 0});
      rows.push_back(static_cast<int>(g));
    }
  }
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0, 1);
  const int extra = 20;
  f.local.resize(static_cast<int>(rows.size()) + extra, kDescriptorSize);
  f.context.resize(static_cast<int>(rows.size()) + extra, kDescriptorSize);
  for (size_t i = 0; i < rows.size(); ++i) {
    f.local.row(i) = map.LocalMeanRow(rows[i]);
    f.context.row(i) = map.ContextMeanRow(rows[i]);
  }
  for (int i = 0; i < extra; ++i) {
    const int r = static_cast<int>(rows.size()) + i;
    for (int c = 0; c < kDescriptorSize; ++c) {
      f.local(r, c) = std::abs(n(rng));
      f.context(r, c) = std::abs(n(rng));
    }
    f.local.row(r).normalize();
    f.context.row(r).normalize();
    f.keypoints.push_back({float(rng() % 600), float(rng() % 300), 4, 0, 1, 0});
  }
  return f;
}

// L(l) from the library equals eq. 3 computed pair by pair from the reference S_D and S_N.
TEST(LocaliserTest, LikelihoodsMatchBruteForceEquationThree) {
  const Map map = test::MakeRandomMap(15, 400, 21);
  const FeatureSet f = FeaturesOfImage(map, 7, 1);
  MatchOptions options;
  options.max_matches_per_landmark = 0;  // the equation itself, without the work budget
  const auto all = ComputeDescriptorMatches(f, map, float(options.s_min), nullptr);
  std::vector<float> best(map.num_landmarks(), 0);
  for (const auto& m : all) {
    const float s_n = NeighbourhoodSimilarity(f, map, all, m.feature, m.landmark, true, 0);
    best[m.landmark] = std::max(best[m.landmark], m.similarity * s_n);
  }
  ThreadPool pool(2);
  LocaliseResult stats;
  const auto scores = ScoreLocations(f, map, options, &pool, &stats);
  ASSERT_TRUE(scores.ok()) << scores.status().ToString();
  const std::vector<float>* got = &scores->likelihood;
  for (int l = 0; l < map.num_images(); ++l) {
    double sum = 0;
    const uint32_t b = map.image_offsets[l], e = map.image_offsets[l + 1];
    for (uint32_t k = b; k < e; ++k) sum += best[map.image_landmarks[k]];
    EXPECT_NEAR((*got)[l], e > b ? sum / (e - b) : 0.0, 1e-5) << "location " << l;
  }
}

// Ranking and confidence: best first, top_k long, confidence = L1 / (L1 + L2); with S_D
// alone the image whose landmarks were all seen scores L = 1 and wins.
TEST(LocaliserTest, RanksAndComputesConfidence) {
  const Map map = test::MakeRandomMap(15, 400, 22);
  const FeatureSet f = FeaturesOfImage(map, 7, 2);
  MatchOptions options;
  options.use_neighbourhood = false;
  options.verify_top = 0;  // rank by L alone, the paper's eq. 3, with its confidence
  options.use_holistic = false;
  options.confidence_model = "paper";
  options.top_k = 4;
  const auto r = Localise(f, map, options, nullptr);
  ASSERT_TRUE(r.ok());
  ASSERT_EQ(r->ranked.size(), 4u);
  EXPECT_FLOAT_EQ(r->ranked[0].likelihood, 1.0f);
  EXPECT_EQ(r->ranked[0].image_name, map.image_names[r->ranked[0].index]);
  for (size_t i = 1; i < r->ranked.size(); ++i) {
    EXPECT_LE(r->ranked[i].likelihood, r->ranked[i - 1].likelihood);
  }
  const float l1 = r->ranked[0].likelihood, l2 = r->ranked[1].likelihood;
  EXPECT_NEAR(r->confidence, l1 / (l1 + l2), 1e-6);
  EXPECT_EQ(r->confidence_model, ConfidenceModel::kPaper);
  EXPECT_GT(r->descriptor_matches, 0u);
}

// Verification re-ranks the best candidates: the frame's own tour image has every
// correspondence as an epipolar inlier at equal keypoint sizes, so it comes first, with
// its inlier count and a zero scale log-ratio reported.
TEST(LocaliserTest, VerificationRanksTheTrueImageFirst) {
  const Map map = test::MakeRandomMap(15, 600, 25);
  const FeatureSet f = FeaturesOfImage(map, 9, 4);
  MatchOptions options;
  options.verify_top = 5;
  options.verify_scale_sigma = 0.15;
  const auto r = Localise(f, map, options, nullptr);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->ranked[0].index, 9);
  EXPECT_GE(r->ranked[0].inliers, 8);
  EXPECT_NEAR(r->ranked[0].log_scale, 0.0f, 1e-6);
  EXPECT_GT(r->confidence, 0.5f);
  for (size_t i = 1; i < r->ranked.size(); ++i) {
    if (r->ranked[i].inliers >= 0) {
      EXPECT_LE(r->ranked[i].inliers, r->ranked[0].inliers);
    }
  }
}

// A result read again with a camera answers as Localise with that camera does: the same
// ranking (the verified candidates, then the rest by L), scores, confidence and decision.
// A robot camera whose sizes are 1.35x the tour's is what the camera changes.
TEST(LocaliserTest, ReadWithCameraIsLocaliseWithThatCamera) {
  const Map map = test::MakeRandomMap(15, 600, 25);
  FeatureSet f = FeaturesOfImage(map, 9, 4);
  for (Keypoint& k : f.keypoints) k.size *= 1.35f;
  MatchOptions tour_camera;
  tour_camera.verify_top = 3;  // fewer candidates than top_k: the rest are ranked by L
  tour_camera.holistic_top = 0;
  tour_camera.top_k = 6;
  tour_camera.verify_scale_sigma = 0.15;
  tour_camera.min_confidence = 0.5;
  MatchOptions robot_camera = tour_camera;
  robot_camera.camera_log_scale = std::log(1.35);
  robot_camera.camera_known = true;
  auto read = Localise(f, map, tour_camera, nullptr);
  const auto direct = Localise(f, map, robot_camera, nullptr);
  ASSERT_TRUE(read.ok() && direct.ok());
  ASSERT_FALSE(read->candidates.empty());
  const double before = read->candidates[0].score;
  ReadWithCamera(map, robot_camera, &*read);
  EXPECT_GT(read->candidates[0].score, before + 1e-3);  // the sizes agree with the camera's
  ASSERT_EQ(read->ranked.size(), direct->ranked.size());
  EXPECT_EQ(read->ranked.size(), 6u);
  for (size_t i = 0; i < direct->ranked.size(); ++i) {
    EXPECT_EQ(read->ranked[i].index, direct->ranked[i].index) << i;
    EXPECT_EQ(read->ranked[i].inliers, direct->ranked[i].inliers) << i;
    EXPECT_FLOAT_EQ(read->ranked[i].likelihood, direct->ranked[i].likelihood) << i;
  }
  EXPECT_EQ(read->ranked[0].index, 9);
  ASSERT_EQ(read->candidates.size(), direct->candidates.size());
  for (size_t i = 0; i < direct->candidates.size(); ++i) {
    EXPECT_EQ(read->candidates[i].location, direct->candidates[i].location) << i;
    EXPECT_DOUBLE_EQ(read->candidates[i].score, direct->candidates[i].score) << i;
  }
  EXPECT_EQ(read->location_scores, direct->location_scores);
  EXPECT_FLOAT_EQ(read->confidence, direct->confidence);
  EXPECT_EQ(read->decision, direct->decision);
  // And back: read with the tour's camera, it is the first answer again.
  const auto first = Localise(f, map, tour_camera, nullptr);
  ReadWithCamera(map, tour_camera, &*read);
  EXPECT_EQ(read->location_scores, first->location_scores);
  EXPECT_FLOAT_EQ(read->confidence, first->confidence);
  EXPECT_EQ(read->ranked[0].index, first->ranked[0].index);
  // More candidates than top_k, and the paper's confidence (L alone) kept as it was.
  tour_camera.verify_top = 8;
  tour_camera.top_k = 3;
  tour_camera.confidence_model = "paper";
  robot_camera = tour_camera;
  robot_camera.camera_log_scale = std::log(1.35);
  robot_camera.camera_known = true;
  auto paper = Localise(f, map, tour_camera, nullptr);
  const auto paper_direct = Localise(f, map, robot_camera, nullptr);
  ASSERT_TRUE(paper.ok() && paper_direct.ok());
  ASSERT_EQ(paper->confidence_model, ConfidenceModel::kPaper);
  ReadWithCamera(map, robot_camera, &*paper);
  ASSERT_EQ(paper->ranked.size(), 3u);
  for (size_t i = 0; i < 3; ++i) EXPECT_EQ(paper->ranked[i].index, paper_direct->ranked[i].index);
  EXPECT_FLOAT_EQ(paper->confidence, paper_direct->confidence);
  EXPECT_EQ(paper->confidence_model, ConfidenceModel::kPaper);
  // A calibrated result read with options that name the paper's model stays calibrated.
  ReadWithCamera(map, tour_camera, &*read);
  EXPECT_EQ(read->confidence_model, ConfidenceModel::kCalibrated);
}

// Untrusted feature sets: mismatched counts and non-finite numbers are refused.
// The camera a frame's shape implies: the tour's for the tour frame's shape at any
// resolution; for another shape, halfway between the tour camera's horizontal field of view
// and its vertical one, doubted by half the distance.
TEST(LocaliserTest, FrameCameraIsHalfwayBetweenTheFieldsOfView) {
  Map map;
  map.image_width = 640;
  map.image_height = 360;
  for (const auto& [w, h] : {std::pair{640, 360}, {320, 180}, {960, 540}, {642, 360}, {0, 360}}) {
    const FrameCameraGuess same = FrameCamera(w, h, map);
    EXPECT_EQ(same.log_scale, 0) << w << "x" << h;
    EXPECT_EQ(same.doubt, 0) << w << "x" << h;
  }
  const double four_thirds = std::log(4.0 / 3.0);
  // 4:3 frames, the sides cut off or the top and bottom added: brought to the map's width,
  // a camera of the tour's vertical field of view sees things 4/3 larger.
  for (const auto& [w, h] : {std::pair{480, 360}, {640, 480}, {160, 120}}) {
    const FrameCameraGuess g = FrameCamera(w, h, map);
    EXPECT_NEAR(g.log_scale, four_thirds / 2, 1e-9) << w << "x" << h;
    EXPECT_NEAR(g.doubt, four_thirds / 2, 1e-9) << w << "x" << h;
  }
  const FrameCameraGuess wider = FrameCamera(640, 270, map);  // 64:27 against 16:9
  EXPECT_NEAR(wider.log_scale, -four_thirds / 2, 1e-9);
  EXPECT_NEAR(wider.doubt, four_thirds / 2, 1e-9);
  // An extreme shape stays within the scales a request may state; its doubt says how wide.
  const FrameCameraGuess sliver = FrameCamera(16, 4000, map);
  EXPECT_DOUBLE_EQ(sliver.log_scale, std::log(kMaxCameraScale));
  EXPECT_GT(sliver.doubt, 2.0);
  EXPECT_DOUBLE_EQ(FrameCamera(4000, 16, map).log_scale, std::log(kMinCameraScale));
}

// Localise reads a frame of another shape with the camera its shape implies unless the
// camera is known, and says which it used; a known camera is used as given.
TEST(LocaliserTest, AnUnknownCameraIsTheFramesShapes) {
  const Map map = test::MakeRandomMap(15, 600, 25);
  FeatureSet f = FeaturesOfImage(map, 9, 4);
  f.image_height = map.image_width * 3 / 4;  // a 4:3 frame of the 16:9 tour's width
  const FrameCameraGuess guess = FrameCamera(f.image_width, f.image_height, map);
  ASSERT_GT(guess.log_scale, 0.1);
  MatchOptions unknown;
  unknown.holistic_top = 0;
  const auto assumed = Localise(f, map, unknown, nullptr);
  ASSERT_TRUE(assumed.ok()) << assumed.status().ToString();
  EXPECT_EQ(assumed->camera_log_scale, guess.log_scale);
  EXPECT_EQ(assumed->camera_log_doubt, guess.doubt);
  MatchOptions as_guessed = unknown;
  as_guessed.camera_known = true;
  as_guessed.camera_log_scale = guess.log_scale;
  as_guessed.camera_log_doubt = guess.doubt;
  const auto given = Localise(f, map, as_guessed, nullptr);
  ASSERT_TRUE(given.ok());
  EXPECT_EQ(given->location_scores, assumed->location_scores);
  EXPECT_FLOAT_EQ(given->confidence, assumed->confidence);
  MatchOptions tour = unknown;
  tour.camera_known = true;  // the tour's camera, stated
  const auto stated = Localise(f, map, tour, nullptr);
  ASSERT_TRUE(stated.ok());
  EXPECT_EQ(stated->camera_log_scale, 0);
  EXPECT_EQ(stated->camera_log_doubt, 0);
  EXPECT_NE(stated->location_scores, assumed->location_scores);  // the scale cue moved
  // A frame of the tour's shape: the tour's camera, known or not.
  f.image_height = map.image_height;
  const auto framed = Localise(f, map, unknown, nullptr);
  ASSERT_TRUE(framed.ok());
  EXPECT_EQ(framed->camera_log_scale, 0);
  EXPECT_EQ(framed->location_scores, stated->location_scores);
}

TEST(LocaliserTest, RefusesMalformedFeatureSets) {
  const Map map = test::MakeRandomMap(5, 50, 23);
  FeatureSet f = FeaturesOfImage(map, 2, 3);
  FeatureSet short_local = f;
  short_local.local.conservativeResize(f.size() - 1, kDescriptorSize);
  EXPECT_EQ(Localise(short_local, map, {}, nullptr).status().code(), StatusCode::kInvalidArgument);
  FeatureSet nan = f;
  nan.context(0, 5) = std::nanf("");
  EXPECT_EQ(Localise(nan, map, {}, nullptr).status().code(), StatusCode::kInvalidArgument);
  FeatureSet inf_x = f;
  inf_x.keypoints[0].x = INFINITY;
  EXPECT_EQ(Localise(inf_x, map, {}, nullptr).status().code(), StatusCode::kInvalidArgument);
  MatchOptions bad;
  bad.s_min = 0;
  EXPECT_EQ(Localise(f, map, bad, nullptr).status().code(), StatusCode::kInvalidArgument);
}

// An empty frame gives no answer and zero confidence, not an error.
TEST(LocaliserTest, EmptyFrameHasZeroConfidence) {
  const Map map = test::MakeRandomMap(5, 50, 24);
  FeatureSet f;
  f.image_width = 100;
  f.image_height = 100;
  const auto r = Localise(f, map, {}, nullptr);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->confidence, 0.0f);
  EXPECT_EQ(r->decision, Decision::kUnknown);
  EXPECT_EQ(r->ranked[0].likelihood, 0.0f);
}

}  // namespace
}  // namespace sceneloc

namespace sceneloc {
namespace {

// A hostile query: 8,192 copies of one landmark's descriptors at one point. Without a
// work budget every copy matches that landmark and S_N walks all of them for every
// neighbour (the issue measured a minute of CPU); with max_matches_per_landmark the
// matches kept, and so the work, are bounded, and the answer is still an answer.
TEST(LocaliserTest, ManyIdenticalFeaturesAreBoundedByTheWorkBudget) {
  const Map map = test::MakeRandomMap(10, 200, 5);
  FeatureSet f;
  f.image_width = map.image_width;
  f.image_height = map.image_height;
  constexpr int kCopies = 8192;
  f.keypoints.assign(kCopies, {100, 100, 4, 0, 1, 0});
  f.local = map.LocalMeanRow(0).replicate(kCopies, 1);
  f.context = map.ContextMeanRow(0).replicate(kCopies, 1);
  MatchOptions options;  // max_matches_per_landmark 32
  const auto capped = Localise(f, map, options, nullptr);
  ASSERT_TRUE(capped.ok()) << capped.status().ToString();
  EXPECT_LE(capped->descriptor_matches, static_cast<size_t>(32 * map.num_landmarks()));
  EXPECT_GE(capped->descriptor_matches, 32u);  // landmark 0 itself keeps its 32
  EXPECT_FALSE(capped->ranked.empty());
  options.max_matches_per_landmark = -1;
  EXPECT_FALSE(Localise(f, map, options, nullptr).ok());
}

// The cap keeps each landmark's best features, still ordered by landmark, then feature.
TEST(LocaliserTest, MatchCapKeepsTheBestInOrder) {
  const Map map = test::MakeRandomMap(6, 60, 9);
  const FeatureSet f = FeaturesOfImage(map, 2, 4);
  const auto all = ComputeDescriptorMatches(f, map, 0.3f, nullptr, 0);
  const auto capped = ComputeDescriptorMatches(f, map, 0.3f, nullptr, 1);
  std::vector<float> best(static_cast<size_t>(map.num_landmarks()), 0.0f);
  for (const DescriptorMatch& m : all) best[m.landmark] = std::max(best[m.landmark], m.similarity);
  for (size_t i = 0; i < capped.size(); ++i) {
    EXPECT_FLOAT_EQ(capped[i].similarity, best[capped[i].landmark]);
    if (i > 0) {
      EXPECT_LT(capped[i - 1].landmark, capped[i].landmark);
    }
  }
  size_t matched_landmarks = 0;
  for (float b : best) matched_landmarks += b > 0;
  EXPECT_EQ(capped.size(), matched_landmarks);
}

// A deadline already past ends the call after its first stage, naming it and the times.
TEST(LocaliserTest, PastDeadlineIsDeadlineExceeded) {
  const Map map = test::MakeRandomMap(6, 60, 9);
  const FeatureSet f = FeaturesOfImage(map, 2, 4);
  MatchOptions options;
  options.deadline = std::chrono::steady_clock::now() - std::chrono::milliseconds(1);
  const auto r = Localise(f, map, options, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kDeadlineExceeded);
  EXPECT_NE(r.status().message().find("after the descriptor stage (descriptor"), std::string::npos)
      << r.status().message();
  options.deadline = std::chrono::steady_clock::now() + std::chrono::hours(1);
  EXPECT_TRUE(Localise(f, map, options, nullptr).ok());
}

}  // namespace
}  // namespace sceneloc
