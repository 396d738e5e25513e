#include "common/matching/sequence_filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>
#include <vector>

#include "common/matching/evidence.h"
#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 200;

class SequenceFilterTest : public ::testing::Test {
 protected:
  SequenceFilterTest() : map_(test::MakeRandomMap(kLocations, 400, 7)), rng_(11) {
    options_.max_forward = 3;
    options_.max_backward = 2;
  }

  // Single-frame evidence of a frame at `where`: a peak of `height` robust-z units there,
  // its neighbours close behind (they share most landmarks), noise everywhere, and with
  // `decoy` >= 0 a look-alike at `decoy` that beats the true place (a wrong single answer).
  FrameEvidence Frame(int where, double height = 4, int decoy = -1, double in_map = 0.95) {
    std::normal_distribution<float> noise(0, 0.4f);
    FrameEvidence e;
    e.in_map = in_map;
    e.location_scores.resize(kLocations);
    for (int l = 0; l < kLocations; ++l) {
      const double d = l - where;
      e.location_scores[l] = static_cast<float>(height * std::exp(-d * d / 2)) + noise(rng_);
    }
    if (decoy >= 0) e.location_scores[decoy] = static_cast<float>(height + 1);
    return e;
  }

  // A frame at `where` seen by a camera that makes everything exp(camera) times larger than
  // the tour's, with its verified candidates: the tour frames within 3 of it, inliers
  // peaking at `where` (40, 4 fewer per frame away), log scales falling 0.1 per frame from
  // the frames behind (things looked smaller from there) to those ahead, through `camera`
  // at `where`; a gentle holistic peak. Its scores are fused as the localiser does, with
  // the tour's camera assumed (0).
  FrameEvidence CameraFrame(int where, double camera) {
    std::normal_distribution<float> noise(0, 0.1f);
    std::vector<float> holistic_z(kLocations);
    for (int l = 0; l < kLocations; ++l) {
      const double d = l - where;
      holistic_z[l] = static_cast<float>(2 * std::exp(-d * d / 8)) + noise(rng_);
    }
    FrameEvidence e;
    e.in_map = 0.95;
    for (int d = -3; d <= 3; ++d) {
      const int l = where + d;
      if (l < 0 || l >= kLocations) continue;
      CandidateEvidence c;
      c.location = l;
      c.holistic = 0.5f;
      c.holistic_z = holistic_z[l];
      c.inliers = 40 - 4 * std::abs(d);
      c.log_scale = static_cast<float>(camera - 0.1 * d);
      e.candidates.push_back(c);
    }
    e.location_scores = LocationScores(e.candidates, holistic_z, kLocations, e.fusion);
    return e;
  }

  // An off-route frame: nothing stands out, and the holistic check says "not here".
  FrameEvidence Elsewhere() { return Frame(0, 0, -1, 0.02); }

  SequenceFilter Filter() const { return SequenceFilter(map_, options_); }

  Map map_;
  std::mt19937 rng_;
  SequenceOptions options_;
};

// A steady walk with every third single-frame answer fooled by a distant look-alike: once
// the session has seen a few frames, the filtered answer stays on the true place.
TEST_F(SequenceFilterTest, SteadyWalkIgnoresLookAlikes) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 60; ++t) {
    const int where = 20 + t;
    const int decoy = t % 3 == 2 ? (where + 90) % kLocations : -1;
    const SequenceAnswer a = filter.Update(Frame(where, 4, decoy), &state);
    EXPECT_EQ(a.frames, static_cast<uint32_t>(t + 1));
    if (t < 3) continue;
    EXPECT_LE(std::abs(a.location - where), 2) << "frame " << t;
    // LOCALISED through the look-alikes once the frames have shown the track a while (a
    // session's support of its track starts at even odds).
    if (t >= 6) {
      EXPECT_EQ(a.decision, Decision::kLocalised) << "frame " << t;
    }
  }
}

// A street that repeats itself: every place l < 100 has a twin at l + 100 that scores a
// little higher in every frame (chance differences that happen to favour it). A map that
// does not know its look-alikes follows the twin with confidence; one that does (each
// twin's look-alike ratio 1, as training measures an exact repeat) never answers LOCALISED
// away from the truth in 20 frames, and on a part of the route without look-alikes it
// answers as before.
TEST_F(SequenceFilterTest, AMapThatKnowsItsTwinsIsNotSureOfTheWrongOne) {
  Map twins = map_;
  twins.lookalike_offsets.assign(1, 0);
  for (int l = 0; l < kLocations; ++l) {
    if (l < 150) {
      twins.lookalike_location.push_back(static_cast<uint32_t>(l < 100 ? l + 100 : l - 100));
      twins.lookalike_ratio.push_back(1.0f);
    }
    twins.lookalike_offsets.push_back(static_cast<uint32_t>(twins.lookalike_location.size()));
  }
  // Places 100-149 are twins of 0-49; 150-199 have none.
  const auto twin_frame = [this](int where) {
    FrameEvidence e = Frame(where, 4);
    for (int l = 0; l < kLocations; ++l) {
      const double d = l - (where + 100);
      e.location_scores[l] += static_cast<float>(4.5 * std::exp(-d * d / 2));
    }
    return e;
  };
  int wrong_unaware = 0;
  const SequenceFilter unaware(map_, options_), aware(twins, options_);
  SequenceState unaware_state, aware_state;
  for (int t = 0; t < 20; ++t) {
    const int where = 10 + t;
    const FrameEvidence e = twin_frame(where);
    const SequenceAnswer u = unaware.Update(e, &unaware_state);
    const SequenceAnswer a = aware.Update(e, &aware_state);
    wrong_unaware += u.decision == Decision::kLocalised && std::abs(u.location - where) > 2;
    EXPECT_FALSE(a.decision == Decision::kLocalised && std::abs(a.location - where) > 2)
        << "frame " << t << ": " << a.location << " at " << a.probability;
  }
  EXPECT_GT(wrong_unaware, 8);  // the failure the look-alikes prevent

  SequenceState plain_state, twins_state;
  for (int t = 0; t < 20; ++t) {
    const FrameEvidence e = Frame(160 + t);
    const SequenceAnswer p = unaware.Update(e, &plain_state);
    const SequenceAnswer a = aware.Update(e, &twins_state);
    EXPECT_EQ(a.location, p.location) << "frame " << t;
    EXPECT_NEAR(a.probability, p.probability, 0.02) << "frame " << t;
    EXPECT_EQ(a.decision, p.decision) << "frame " << t;
  }
}

// A robot standing still: the answer stays put and its probability stays high.
TEST_F(SequenceFilterTest, StandingStill) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  SequenceAnswer a;
  for (int t = 0; t < 20; ++t) a = filter.Update(Frame(100), &state);
  EXPECT_LE(std::abs(a.location - 100), 1);
  EXPECT_GT(a.probability, 0.9);  // the evidence places it within a frame or two (spread)
}

// The robot's pace is state: a robot walking three locations a frame keeps that pace
// through frames without evidence (a band of steps 0..4 each equally likely predicted two
// a frame and fell behind).
TEST_F(SequenceFilterTest, KeepsAFastPaceThroughFramesWithoutEvidence) {
  options_.max_forward = 4;
  options_.max_backward = 4;
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 20; ++t) filter.Update(Frame(20 + 3 * t), &state);
  SequenceAnswer a;
  for (int t = 0; t < 5; ++t) a = filter.Update(FrameEvidence{}, &state);
  EXPECT_LE(std::abs(a.location - (20 + 3 * 24)), 2) << a.location;
}

// A robot that walks one location a frame and then, at once, three: the speed drawn afresh
// now and then (speed_jump) lets the belief take up the new pace sooner than half a
// location per frame at a time, and the steady walk before is answered as well.
TEST_F(SequenceFilterTest, SpeedJumpFollowsASuddenChangeOfPace) {
  options_.max_forward = 4;
  options_.max_backward = 4;
  options_.speed_change = 0.02;
  const auto wrong_answers = [&](double speed_jump, int* before) {
    options_.speed_jump = speed_jump;
    const SequenceFilter filter = Filter();
    SequenceState state;
    rng_.seed(5);
    int after = 0;
    *before = 0;
    for (int t = 0; t < 60; ++t) {
      const int where = t < 30 ? 20 + t : 50 + 3 * (t - 30);
      const SequenceAnswer a = filter.Update(Frame(where, 2.5, t % 4 == 3 ? 10 : -1), &state);
      const bool wrong = std::abs(a.location - where) > 2;
      if (t >= 5 && t < 30) *before += wrong ? 1 : 0;
      if (t >= 30) after += wrong ? 1 : 0;
    }
    return after;
  };
  int steady_without = 0, steady_with = 0;
  const int without = wrong_answers(0, &steady_without);
  const int with = wrong_answers(0.02, &steady_with);
  EXPECT_LT(with, without);
  EXPECT_LE(steady_with, steady_without);
}

// A robot that sends three frames per tour location (a slower walk, or a faster camera
// than the tour's) is followed too, and its answers do not run ahead of it.
TEST_F(SequenceFilterTest, FollowsASlowWalk) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  int wrong = 0;
  for (int t = 0; t < 90; ++t) {
    const int where = 40 + t / 3;
    const SequenceAnswer a = filter.Update(Frame(where, 3, t % 7 == 6 ? 150 : -1), &state);
    if (t >= 6) wrong += std::abs(a.location - where) > 1 ? 1 : 0;
  }
  EXPECT_LE(wrong, 3);
}

// Without evidence the prediction alone keeps a uniform belief uniform: a step past an end
// of the route turns round there instead of piling up on the end location (which answered
// a robot standing near the start of the corridor's route at its first frame).
TEST_F(SequenceFilterTest, EndsOfTheRouteGatherNoBelief) {
  options_.max_forward = 2;  // the same band both ways, as the map's default
  options_.max_backward = 2;
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 12; ++t) filter.Update(FrameEvidence{}, &state);
  const double off = state.location[kLocations];
  const double each = (1 - off) / kLocations;
  for (int l = 0; l < kLocations; ++l) EXPECT_NEAR(state.location[l], each, each * 1e-4) << l;
}

// A robot standing near the start of the route with weak evidence is answered where it
// stands, not at the route's first location.
TEST_F(SequenceFilterTest, StandingNearTheStartOfTheRoute) {
  options_.max_forward = 2;  // the same band both ways, as the map's default
  options_.max_backward = 2;
  const SequenceFilter filter = Filter();
  FrameEvidence weak;  // a broad, noiseless bump at location 2
  weak.in_map = 0.95;
  weak.location_scores.resize(kLocations);
  for (int l = 0; l < kLocations; ++l) {
    weak.location_scores[l] = static_cast<float>(std::exp(-(l - 2.0) * (l - 2.0) / 8));
  }
  SequenceState state;
  for (int t = 0; t < 15; ++t) {
    EXPECT_LE(std::abs(filter.Update(weak, &state).location - 2), 1) << "frame " << t;
  }
}

TEST(SequenceFilterReflectTest, StepsPastTheEndsTurnRound) {
  bool turned = true;
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(5, 10, &turned), 5);
  EXPECT_FALSE(turned);
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(-1, 10, &turned), 0);
  EXPECT_TRUE(turned);
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(-3, 10, &turned), 2);
  EXPECT_TRUE(turned);
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(10, 10, &turned), 9);
  EXPECT_TRUE(turned);
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(12, 10, &turned), 7);
  EXPECT_TRUE(turned);
  // Steps longer than the route fold back and forth: on one location everything lands on it.
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(2, 1, &turned), 0);
  EXPECT_FALSE(turned);
  EXPECT_EQ(SequenceFilter::ReflectAtEnds(-4, 3, &turned), 2);
  EXPECT_FALSE(turned);
}

// Walking backwards along the route is followed too (within the backward band).
TEST_F(SequenceFilterTest, WalkingBackwards) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 40; ++t) {
    const int where = 150 - t;
    const SequenceAnswer a = filter.Update(Frame(where, 4, t % 4 == 3 ? 10 : -1), &state);
    if (t >= 3) {
      EXPECT_LE(std::abs(a.location - where), 2) << "frame " << t;
    }
  }
}

// A robot that walks up the route, turns round and walks back down it at the same pace
// (backs up, say), with evidence that alone is often wrong: the session follows it down
// within a few frames of the turn and stays on it. (Before the direction of travel was
// state, a band with backward steps at every frame lagged a walk down the route and lost
// it to the look-alikes.) The turn here is instant, from one location a frame up to one
// down: the speed must pass four half-location changes, which a robot keeping its pace
// (speed_change 0.02) makes reluctantly, or with a speed drawn afresh (speed_jump 0.01), so for a
// few frames the answer lags the turn by up to three locations, never sure of it: no wrong answer
// is LOCALISED, and from the sixth frame on at most one is wrong.
TEST_F(SequenceFilterTest, TurnsRoundAndWalksBack) {
  options_.max_forward = 2;
  options_.max_backward = 2;
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 40; ++t) filter.Update(Frame(40 + t, 1.5), &state);
  int wrong = 0;
  for (int t = 0; t < 40; ++t) {
    const int where = 79 - t;  // down one location per frame
    const SequenceAnswer a = filter.Update(Frame(where, 1.5, t % 3 == 2 ? 150 : -1), &state);
    const bool right = std::abs(a.location - where) <= 2;
    EXPECT_TRUE(right || a.decision == Decision::kUnknown) << "frame " << t << ": " << a.location;
    if (t >= 6) wrong += right ? 0 : 1;
  }
  EXPECT_LE(wrong, 1);
}

// A robot walking on at the tour's pace through frames without evidence (a dark stretch,
// a blank wall) is predicted where it has got to: travelling up the route it moves 0-2
// locations a frame, one on average, as it did before the gap. (A band with backward steps
// at every frame averaged under one a frame and fell behind across the gap.)
TEST_F(SequenceFilterTest, KeepsPaceThroughFramesWithoutEvidence) {
  options_.max_forward = 2;
  options_.max_backward = 2;
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 20; ++t) filter.Update(Frame(60 + t), &state);
  SequenceAnswer a;
  for (int t = 0; t < 6; ++t) a = filter.Update(FrameEvidence{}, &state);
  EXPECT_LE(std::abs(a.location - 85), 1);  // the walk's place after the gap
}

// The kidnapped robot: carried from location 40 to 160, it is found again within a few
// frames.
TEST_F(SequenceFilterTest, KidnappedRobotIsFoundAgain) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 30; ++t) filter.Update(Frame(10 + t), &state);
  int found_after = -1;
  for (int t = 0; t < 20; ++t) {
    const SequenceAnswer a = filter.Update(Frame(160 + t), &state);
    if (std::abs(a.location - (160 + t)) <= 2 && a.decision == Decision::kLocalised) {
      found_after = t;
      break;
    }
  }
  ASSERT_GE(found_after, 0) << "never found again";
  EXPECT_LE(found_after, 5);
}

// Frames without evidence (no features): the session predicts at its speed, keeps
// its place, counts the frames, and becomes less sure.
TEST_F(SequenceFilterTest, FramesWithoutEvidencePredictOnly) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  SequenceAnswer before;
  for (int t = 0; t < 10; ++t) before = filter.Update(Frame(50 + t), &state);
  SequenceAnswer a;
  for (int t = 0; t < 3; ++t) a = filter.Update(FrameEvidence{}, &state);
  EXPECT_EQ(a.frames, 13u);
  EXPECT_GE(a.location, before.location);  // the band leans forward
  EXPECT_LE(a.location, before.location + 3 * options_.max_forward);
  EXPECT_LT(a.probability, before.probability);
  // Evidence again: back on track at once.
  a = filter.Update(Frame(62), &state);
  EXPECT_LE(std::abs(a.location - 62), 2);
}

// Frames from off the route come back UNKNOWN with the belief on "off the map"; frames of
// the route again are LOCALISED again.
TEST_F(SequenceFilterTest, OffTheMapAndBack) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 10; ++t) filter.Update(Frame(30 + t), &state);
  SequenceAnswer a;
  for (int t = 0; t < 8; ++t) a = filter.Update(Elsewhere(), &state);
  EXPECT_EQ(a.decision, Decision::kUnknown);
  EXPECT_GT(a.off_map, 0.8);
  for (int t = 0; t < 6; ++t) a = filter.Update(Frame(120 + t), &state);
  EXPECT_EQ(a.decision, Decision::kLocalised);
  EXPECT_LE(std::abs(a.location - 125), 2);
}

// A first frame of an off-route place is UNKNOWN: a session does not start out sure.
TEST_F(SequenceFilterTest, FirstFrameElsewhereIsUnknown) {
  SequenceState state;
  EXPECT_EQ(Filter().Update(Elsewhere(), &state).decision, Decision::kUnknown);
}

// A state that does not fit (another map's, other settings', tracked locations out of
// order) is restarted, never read.
TEST_F(SequenceFilterTest, ForeignStateRestarts) {
  const SequenceFilter filter = Filter();
  SequenceState fits;
  filter.Update(Frame(30), &fits);
  ASSERT_TRUE(filter.Fits(fits));
  fits.camera_counts.assign(SequenceOptions::kCameraBins, 1);
  ASSERT_TRUE(filter.Fits(fits));
  std::vector<SequenceState> foreign(5, fits);
  foreign[0].location.assign(17, 1.0f / 17);  // another map
  foreign[1].speeds.pop_back();               // other speeds
  std::swap(foreign[2].tracked[0], foreign[2].tracked[1]);
  foreign[3].tracked.back() = kLocations;  // past the map
  foreign[4].camera_counts.pop_back();     // another camera histogram
  for (SequenceState& state : foreign) {
    EXPECT_FALSE(filter.Fits(state));
    state.frames = 99;
    const SequenceAnswer a = filter.Update(Frame(70), &state);
    EXPECT_EQ(a.frames, 1u);
    EXPECT_TRUE(state.camera_counts.empty());  // Frame() has no candidates to measure
    EXPECT_TRUE(filter.Fits(state));
    EXPECT_LE(std::abs(a.location - 70), 2);
  }
}

// A robot whose camera sees everything 1.35x larger than the tour's (a narrower lens): the
// scale cue, read from the tour camera's scale, prefers the frames ahead where things
// looked that large, and the session answers 2-3 frames ahead of the robot. Learning the
// camera's scale from its LOCALISED frames, the session reads its frames with it and
// answers where the robot is.
TEST_F(SequenceFilterTest, LearnsTheScaleOfAnotherCamera) {
  const double camera = 0.3;
  const auto walk = [&](bool learn, double* learnt) {
    options_.learn_camera_scale = learn;
    const SequenceFilter filter = Filter();
    SequenceState state;
    double ahead = 0;
    for (int t = 0; t < 60; ++t) {
      const SequenceAnswer a = filter.Update(CameraFrame(40 + t, camera), &state);
      if (t >= 40) ahead += (a.location - (40 + t)) / 20.0;
      *learnt = a.camera_log_scale;
    }
    return ahead;
  };
  double learnt = 0;
  EXPECT_GT(walk(false, &learnt), 1.5);
  EXPECT_EQ(learnt, 0);
  EXPECT_LT(std::abs(walk(true, &learnt)), 0.5);
  EXPECT_NEAR(learnt, camera, 0.05);
}

// A camera its client states (LocaliseRequest.camera_scale) is the one every frame is read
// with, from the first, whatever the session learns meanwhile: the session answers where
// the robot is, with learning off too, and goes on measuring.
TEST_F(SequenceFilterTest, AStatedCameraIsReadFromTheFirstFrame) {
  const double camera = 0.3;
  for (const bool learn : {false, true}) {
    options_.learn_camera_scale = learn;
    const SequenceFilter filter = Filter();
    SequenceState state;
    double ahead = 0;
    for (int t = 0; t < 60; ++t) {
      FrameEvidence frame = CameraFrame(40 + t, camera);
      frame.camera_log_scale = camera;
      const SequenceAnswer a = filter.Update(frame, &state);
      EXPECT_EQ(a.camera_log_scale, camera) << "frame " << t;
      if (t >= 40) ahead += (a.location - (40 + t)) / 20.0;
    }
    EXPECT_LT(std::abs(ahead), 0.5) << "learning " << learn;
    EXPECT_EQ(state.camera_counts.empty(), !learn);
    if (learn) {
      EXPECT_NEAR(filter.CameraLogScale(state), camera, 0.05);
    }
    // A stated camera that is wrong shows beside what the session measures.
    FrameEvidence wrong = CameraFrame(100, camera);
    wrong.camera_log_scale = 0;
    const SequenceAnswer a = filter.Update(wrong, &state);
    EXPECT_EQ(a.camera_log_scale, 0);
    EXPECT_NEAR(a.measured_camera_log_scale, learn ? camera : 0, 0.05);
  }
}

// The tour's own camera is learnt as the tour's: the answers are the same as without
// learning, exactly where the robot is.
TEST_F(SequenceFilterTest, TheToursCameraIsLearntAsItself) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 40; ++t) {
    const SequenceAnswer a = filter.Update(CameraFrame(40 + t, 0), &state);
    EXPECT_NEAR(a.camera_log_scale, 0, 0.03) << "frame " << t;
    if (t >= 2) {
      EXPECT_EQ(a.location, 40 + t) << "frame " << t;
    }
  }
  EXPECT_FALSE(state.camera_counts.empty());
}

// Nothing is measured from an answer that is not LOCALISED or from matches too weak to
// trust (below camera_min_inliers); the scale is used only once camera_min_frames
// measurements are in.
TEST_F(SequenceFilterTest, CameraMeasuredOnlyOnClearLocalisedMatches) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  filter.Update(Elsewhere(), &state);  // UNKNOWN
  EXPECT_TRUE(state.camera_counts.empty());
  FrameEvidence weak = CameraFrame(50, 0.3);
  for (CandidateEvidence& c : weak.candidates) c.inliers = options_.camera_min_inliers - 1;
  for (int t = 0; t < 5; ++t) filter.Update(weak, &state);
  EXPECT_TRUE(state.camera_counts.empty());
  SequenceAnswer a;
  for (int t = 0; t < options_.camera_min_frames; ++t) {
    a = filter.Update(CameraFrame(50, 0.3), &state);
    EXPECT_EQ(a.camera_log_scale, 0) << "measurement " << t;
  }
  EXPECT_EQ(std::accumulate(state.camera_counts.begin(), state.camera_counts.end(), 0),
            options_.camera_min_frames);
  EXPECT_GT(filter.Update(CameraFrame(50, 0.3), &state).camera_log_scale, 0.05);
}

// The camera's scale is the median of the measurements' bins, to within a bin; off, or
// with fewer than camera_min_frames, it is 0; saturated counts are halved, not wrapped.
TEST_F(SequenceFilterTest, CameraScaleIsTheMedianOfItsMeasurements) {
  SequenceState state;
  state.camera_counts.assign(SequenceOptions::kCameraBins, 0);
  const auto bin_of = [](double x) {
    return static_cast<int>((x + SequenceOptions::kCameraRange) / SequenceOptions::kCameraBinWidth);
  };
  state.camera_counts[bin_of(-0.5)] = 2;
  state.camera_counts[bin_of(0.21)] = 5;
  state.camera_counts[bin_of(0.6)] = 2;
  EXPECT_NEAR(Filter().CameraLogScale(state), 0.21, SequenceOptions::kCameraBinWidth);
  options_.camera_min_frames = 10;
  EXPECT_EQ(Filter().CameraLogScale(state), 0);
  options_.camera_min_frames = 3;
  options_.learn_camera_scale = false;
  EXPECT_EQ(Filter().CameraLogScale(state), 0);
  options_.learn_camera_scale = true;
  const SequenceFilter filter = Filter();
  SequenceState full;
  for (int t = 0; full.camera_counts.empty() && t < 10; ++t)
    filter.Update(CameraFrame(50, 0), &full);
  ASSERT_EQ(full.camera_counts.size(), static_cast<size_t>(SequenceOptions::kCameraBins));
  const int bin =
      static_cast<int>(std::max_element(full.camera_counts.begin(), full.camera_counts.end()) -
                       full.camera_counts.begin());
  full.camera_counts[bin] = UINT16_MAX;
  full.camera_counts[0] = 7;
  filter.Update(CameraFrame(50, 0), &full);
  EXPECT_EQ(full.camera_counts[0], 3);
  EXPECT_GE(full.camera_counts[bin], UINT16_MAX / 2);
}

// Between frames a state keeps the speeds of the most probable locations only (the others
// share one distribution): num_tracked() of them, ascending, none less probable than a
// location left out.
TEST_F(SequenceFilterTest, StateKeepsTheMostProbableLocationsSpeeds) {
  options_.tracked_locations = 16;
  const SequenceFilter filter = Filter();
  EXPECT_EQ(filter.num_tracked(), 16);
  SequenceState state;
  for (int t = 0; t < 20; ++t) filter.Update(Frame(50 + t, 4, t % 4 == 3 ? 150 : -1), &state);
  ASSERT_EQ(state.tracked.size(), 16u);
  EXPECT_EQ(state.speeds.size(), 17u * static_cast<size_t>(filter.num_speeds()));
  EXPECT_EQ(state.location.size(), static_cast<size_t>(kLocations) + 1);
  std::vector<bool> tracked(kLocations, false);
  float least_tracked = 1;
  for (size_t i = 0; i < state.tracked.size(); ++i) {
    if (i > 0) {
      EXPECT_LT(state.tracked[i - 1], state.tracked[i]);
    }
    tracked[state.tracked[i]] = true;
    least_tracked = std::min(least_tracked, state.location[state.tracked[i]]);
  }
  EXPECT_TRUE(tracked[69]);  // where the robot is
  for (int l = 0; l < kLocations; ++l) {
    if (!tracked[l]) {
      EXPECT_LE(state.location[l], least_tracked) << l;
    }
  }
  // A map smaller than the setting: every location tracked.
  options_.tracked_locations = 1000;
  EXPECT_EQ(Filter().num_tracked(), kLocations);
}

// A state that tracks more or fewer locations than the filter keeps (made by a server with
// another tracked_locations) continues and is compacted to the filter's.
TEST_F(SequenceFilterTest, StatesOfOtherTrackedCountsContinue) {
  for (const auto& [from, to] : {std::pair<int, int>{16, 64}, {64, 16}, {0, 200}}) {
    options_.tracked_locations = from;
    SequenceState state;
    const SequenceFilter before = Filter();
    for (int t = 0; t < 5; ++t) before.Update(Frame(40 + t), &state);
    options_.tracked_locations = to;
    const SequenceFilter after = Filter();
    ASSERT_TRUE(after.Fits(state)) << from << " -> " << to;
    const SequenceAnswer a = after.Update(Frame(45), &state);
    EXPECT_EQ(a.frames, 6u);
    EXPECT_LE(std::abs(a.location - 45), 2);
    EXPECT_EQ(state.tracked.size(), static_cast<size_t>(to));
  }
}

// Compaction is deterministic: among equally probable locations the lower ones keep their
// speeds, so every process compacts a belief alike.
TEST_F(SequenceFilterTest, TiesGoToTheLowerLocation) {
  options_.tracked_locations = 16;
  const SequenceFilter filter = Filter();
  SequenceState state;
  filter.Update(FrameEvidence{}, &state);  // no evidence: a uniform belief
  std::vector<uint32_t> first(16);
  std::iota(first.begin(), first.end(), 0u);
  EXPECT_EQ(state.tracked, first);
}

// With answer_window the answer is where the most belief lies within the tolerance, not
// the single most probable location: a sharp peak at 50 against a broad stretch 120-124
// that holds more in all. Without (the default) the session answers 50, with less belief
// within the tolerance of it.
TEST_F(SequenceFilterTest, AnswersWhereMostBeliefLiesWithinTheTolerance) {
  options_.evidence_spread = 0;  // each location's own evidence: the sums are plain
  options_.answer_window = true;
  FrameEvidence frame;
  frame.in_map = 0.95;
  frame.location_scores.assign(kLocations, 0.0f);
  frame.location_scores[50] = 3.5f;
  for (int l = 120; l <= 124; ++l) frame.location_scores[l] = 2.6f;

  SequenceState windowed;
  const SequenceAnswer broad = Filter().Update(frame, &windowed);
  options_.answer_window = false;
  SequenceState moded;
  const SequenceAnswer sharp = Filter().Update(frame, &moded);

  EXPECT_EQ(broad.location, 122);
  EXPECT_EQ(sharp.location, 50);
  EXPECT_GT(broad.belief, sharp.belief + 0.04);  // 0.345 against 0.298
  // The same belief either way: only the answer read from it differs.
  EXPECT_EQ(windowed.location, moded.location);
}

// With an evidence floor one misleading frame, however sure, costs the true place a bounded
// factor: after a steady walk, a single frame that matches only a distant look-alike leaves
// the session where the robot is, with more belief there than without the floor.
TEST_F(SequenceFilterTest, EvidenceFloorBoundsOneMisleadingFrame) {
  std::vector<double> kept;
  for (const double floor : {0.0, 0.3}) {
    options_.evidence_floor = floor;
    const SequenceFilter filter = Filter();
    SequenceState state;
    for (int t = 0; t < 10; ++t) filter.Update(Frame(50 + t, 4), &state);
    FrameEvidence fooled = Frame(150, 12);  // a confident frame of a place 90 away
    const SequenceAnswer a = filter.Update(fooled, &state);
    double near = 0;
    for (int l = 57; l <= 63; ++l) near += state.location[l];
    kept.push_back(near);
    if (floor > 0) {
      EXPECT_LE(std::abs(a.location - 60), 2);
    }
  }
  EXPECT_GT(kept[1], kept[0]);
  EXPECT_GT(kept[1], 0.5);
}

// A walk whose frames support the track keeps its probability: the support rises to its
// ceiling (the switch rate caps it) and the answer stays LOCALISED, within a few hundredths
// of the belief alone.
TEST_F(SequenceFilterTest, ASupportedTrackKeepsItsProbability) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  SequenceAnswer a;
  for (int t = 0; t < 30; ++t) a = filter.Update(Frame(20 + t), &state);
  EXPECT_GT(a.support, 0.95);
  EXPECT_EQ(state.support, static_cast<float>(a.support));
  EXPECT_EQ(a.decision, Decision::kLocalised);
  EXPECT_GT(a.probability, a.belief - 0.05);
  EXPECT_LE(a.probability, 1.0);
}

// Frames that stop supporting the track (each matches somewhere else, never the same place
// twice: a look-alike stretch, a night from the other side) leave the filter's belief on the
// track it was following, sure of it; the session's probability follows the support down
// and the answer becomes UNKNOWN. Frames that support the track again bring it back.
TEST_F(SequenceFilterTest, ATrackTheFramesStopSupportingIsDoubted) {
  std::vector<SequenceAnswer> lost;
  for (const double weight : {0.0, 0.25}) {
    options_.support_weight = weight;
    const SequenceFilter filter = Filter();
    SequenceState state;
    rng_.seed(11);
    for (int t = 0; t < 20; ++t) filter.Update(Frame(20 + t), &state);
    // The track goes on at a frame a location, but only every third frame shows it; the
    // others each match a place of their own.
    SequenceAnswer a;
    for (int t = 20; t < 32; ++t) {
      a = filter.Update(t % 3 == 0 ? Frame(20 + t) : Frame(80 + 5 * (t - 20), 2), &state);
    }
    lost.push_back(a);
    if (weight == 0) continue;
    EXPECT_LT(a.support, 0.75);
    EXPECT_EQ(a.decision, Decision::kUnknown);
    int back = -1;
    for (int t = 32; t < 52 && back < 0; ++t) {
      a = filter.Update(Frame(20 + t), &state);
      if (a.decision == Decision::kLocalised && std::abs(a.location - (20 + t)) <= 2) back = t - 32;
    }
    EXPECT_GE(back, 0) << "never LOCALISED again";
    EXPECT_LE(back, 8);
  }
  // Off, the probability is the belief alone, and the belief holds the track, sure of it.
  EXPECT_EQ(lost[0].probability, lost[0].belief);
  EXPECT_GE(lost[0].belief, 0.8);
  EXPECT_EQ(lost[1].belief, lost[0].belief);  // the support changes no belief
  EXPECT_LT(lost[1].probability, lost[0].probability - 0.2);
}

// A frame without evidence says nothing about the track: the support only relaxes towards
// even odds at the switch rate.
TEST_F(SequenceFilterTest, FramesWithoutEvidenceLeaveTheSupportToTheSwitch) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 20; ++t) filter.Update(Frame(20 + t), &state);
  const double before = state.support, h = options_.support_switch;
  const SequenceAnswer a = filter.Update(FrameEvidence{}, &state);
  EXPECT_NEAR(a.support, before * (1 - h) + (1 - before) * h, 1e-6);
  EXPECT_EQ(a.probability, a.support * a.belief);  // and the frame's own says nothing
}

// A frame count carried in from a client stops at its largest value instead of wrapping.
TEST_F(SequenceFilterTest, FrameCountSaturates) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  filter.Update(Frame(10), &state);
  state.frames = UINT32_MAX;
  EXPECT_EQ(filter.Update(Frame(11), &state).frames, UINT32_MAX);
}

// Keeping few locations' speeds answers as keeping every one: a walk with look-alikes, a
// change of pace, a turn and a kidnap, filtered with 8 and with all 200 tracked. Where the
// robot is and how fast it goes are nearly independent away from where it might be.
TEST_F(SequenceFilterTest, FewTrackedLocationsAnswerAsAll) {
  std::vector<int> route;
  for (int t = 0; t < 30; ++t) route.push_back(20 + t);       // one location per frame
  for (int t = 0; t < 20; ++t) route.push_back(50 + 2 * t);   // two per frame
  for (int t = 0; t < 20; ++t) route.push_back(90 - t);       // turned round
  for (int t = 0; t < 20; ++t) route.push_back(150 + t / 2);  // carried off, half speed
  std::vector<FrameEvidence> frames;
  for (size_t t = 0; t < route.size(); ++t) {
    frames.push_back(Frame(route[t], 4, t % 5 == 4 ? (route[t] + 100) % kLocations : -1));
  }
  std::vector<std::vector<int>> answers;
  for (const int tracked : {kLocations, 8}) {
    options_.tracked_locations = tracked;
    const SequenceFilter filter = Filter();
    SequenceState state;
    answers.emplace_back();
    for (const FrameEvidence& e : frames)
      answers.back().push_back(filter.Update(e, &state).location);
  }
  int differ = 0, wrong = 0;
  for (size_t t = 0; t < route.size(); ++t) {
    differ += answers[0][t] != answers[1][t] ? 1 : 0;
    wrong += std::abs(answers[1][t] - route[t]) > 2 ? 1 : 0;
  }
  EXPECT_LE(differ, 2);
  EXPECT_LE(wrong, 12);  // the first frames and each change of place
}

// The filter's model written out densely: the full belief over (location, speed) built from
// a state, one frame's prediction and evidence applied cell by cell, and the state kept
// again. The filter never forms the full belief (sequence_filter.h); its steps must equal
// this one's. Evidence without spread or floor (Spread is shared by both).
SequenceState DenseStep(const SequenceState& state, const FrameEvidence& e,
                        const SequenceOptions& o, int forward, int backward, int tracked) {
  const int n = static_cast<int>(state.location.size()) - 1;
  const int speeds = 2 * (forward + backward) + 1;
  std::vector<double> b(static_cast<size_t>(speeds) * n + 1);
  const auto cell = [n](int v, int l) { return static_cast<size_t>(v) * n + l; };
  for (int l = 0; l < n; ++l) {
    const auto it = std::lower_bound(state.tracked.begin(), state.tracked.end(), l);
    const size_t row = it != state.tracked.end() && *it == static_cast<uint32_t>(l)
                           ? static_cast<size_t>(it - state.tracked.begin())
                           : state.tracked.size();
    for (int v = 0; v < speeds; ++v)
      b[cell(v, l)] = state.location[l] * state.speeds[row * speeds + v];
  }
  b.back() = state.location[n];
  const double in_mass = std::accumulate(b.begin(), b.end() - 1, 0.0), off = b.back();
  // The speed changes: half a location slower or faster, or drawn afresh.
  std::vector<double> sped(b.size() - 1, 0.0);
  for (int l = 0; l < n; ++l) {
    double total = 0;
    for (int v = 0; v < speeds; ++v) total += b[cell(v, l)];
    for (int v = 0; v < speeds; ++v) {
      const int ways = (v > 0 ? 1 : 0) + (v + 1 < speeds ? 1 : 0);
      sped[cell(v, l)] += (1 - o.speed_change) * b[cell(v, l)];
      if (v > 0) sped[cell(v - 1, l)] += o.speed_change / ways * b[cell(v, l)];
      if (v + 1 < speeds) sped[cell(v + 1, l)] += o.speed_change / ways * b[cell(v, l)];
    }
    for (int v = 0; v < speeds; ++v) {
      sped[cell(v, l)] = (1 - o.speed_jump) * sped[cell(v, l)] + o.speed_jump / speeds * total;
    }
  }
  // The step: half-location speeds split between the whole steps around them, each give or
  // take one; past an end the robot turns round at the opposite speed.
  std::vector<double> moved(sped.size(), 0.0);
  for (int v = 0; v < speeds; ++v) {
    const int halves = v - 2 * backward;
    const int low = static_cast<int>(std::floor(halves / 2.0));
    for (int l = 0; l < n; ++l) {
      for (const int whole : {low, low + 1}) {
        const double share = halves % 2 != 0 ? 0.5 : (whole == low ? 1.0 : 0.0);
        for (int j = -1; j <= 1; ++j) {
          bool turned = false;
          const int at = SequenceFilter::ReflectAtEnds(l + whole + j, n, &turned);
          const int to_speed =
              turned ? std::clamp(-halves, -2 * backward, 2 * forward) + 2 * backward : v;
          moved[cell(to_speed, l) - l + at] += share * (j == 0 ? 4.0 : 1.0) / 6 * sped[cell(v, l)];
        }
      }
    }
  }
  const double cells = static_cast<double>(speeds) * n;
  for (size_t i = 0; i + 1 < b.size(); ++i) {
    b[i] = (1 - o.leave) * ((1 - o.jump) * moved[i] + o.jump * in_mass / cells) +
           o.enter * off / cells;
  }
  b.back() = o.leave * in_mass + (1 - o.enter) * off;
  // The frame: its posterior over a uniform prior, tempered.
  const std::vector<float>& s = e.location_scores;
  const float top = *std::max_element(s.begin(), s.end());
  double z = 0;
  for (int l = 0; l < n; ++l) z += std::exp((s[l] - top) / o.evidence_temperature);
  for (int l = 0; l < n; ++l) {
    const double lik = std::exp((s[l] - top) / o.evidence_temperature) * e.in_map * n / z;
    for (int v = 0; v < speeds; ++v) b[cell(v, l)] *= std::pow(lik, o.evidence_weight);
  }
  b.back() *= std::pow(1 - e.in_map, o.evidence_weight);
  const double total = std::accumulate(b.begin(), b.end(), 0.0);
  for (double& x : b) x /= total;
  // Kept: every location's belief, the most probable locations' speeds, the others' shared.
  SequenceState out;
  std::vector<double> at(static_cast<size_t>(n), 0.0);
  for (int l = 0; l < n; ++l) {
    for (int v = 0; v < speeds; ++v) at[l] += b[cell(v, l)];
    out.location.push_back(static_cast<float>(at[l]));
  }
  out.location.push_back(static_cast<float>(b.back()));
  std::vector<uint32_t> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&at](uint32_t a, uint32_t c) { return at[a] > at[c]; });
  order.resize(static_cast<size_t>(std::min(tracked, n)));
  std::sort(order.begin(), order.end());
  out.tracked = order;
  std::vector<double> rest(static_cast<size_t>(speeds), 0.0);
  for (int l = 0; l < n; ++l) {
    if (std::binary_search(order.begin(), order.end(), static_cast<uint32_t>(l))) continue;
    for (int v = 0; v < speeds; ++v) rest[v] += b[cell(v, l)];
  }
  const double rest_total = std::accumulate(rest.begin(), rest.end(), 0.0);
  for (const uint32_t l : order) {
    for (int v = 0; v < speeds; ++v)
      out.speeds.push_back(static_cast<float>(b[cell(v, l)] / at[l]));
  }
  for (int v = 0; v < speeds; ++v) {
    out.speeds.push_back(rest_total > 0 ? static_cast<float>(rest[v] / rest_total) : 1.0f / speeds);
  }
  return out;
}

// The filter's sparse step is the dense model's: on a route longer than the tracked
// locations and the steps, on one where every location is tracked, and on one shorter than
// a step (where every step may turn round), through a walk, a kidnap and off-route frames.
TEST_F(SequenceFilterTest, SparseStepsAreTheDenseModels) {
  options_.evidence_spread = 0;
  options_.support_weight = 0;
  options_.learn_camera_scale = false;
  options_.tracked_locations = 16;
  for (const int n : {kLocations, 40, 12, 3}) {
    SCOPED_TRACE(n);
    Map map = map_;
    map.image_names.resize(static_cast<size_t>(n));
    const SequenceFilter filter(map, options_);
    SequenceState state;
    for (int t = 0; t < 60; ++t) {
      const int where = t < 30 ? (2 * t) % n : t < 40 ? (n / 2 + t) % n : (7 * t) % n;
      FrameEvidence e = t % 11 == 10 ? Elsewhere() : Frame(where, 4);
      e.location_scores.resize(static_cast<size_t>(n));
      e.location_scores[0] += 0.01f;  // never flat
      if (t == 0) {
        filter.Update(e, &state);
        continue;
      }
      const SequenceState dense = DenseStep(state, e, options_, filter.max_forward(),
                                            filter.max_backward(), filter.num_tracked());
      filter.Update(e, &state);
      ASSERT_EQ(state.location.size(), dense.location.size());
      for (size_t l = 0; l < dense.location.size(); ++l) {
        ASSERT_NEAR(state.location[l], dense.location[l], 1e-6 + 1e-4 * dense.location[l])
            << "frame " << t << " location " << l;
      }
      ASSERT_EQ(state.tracked, dense.tracked) << "frame " << t;
      ASSERT_EQ(state.speeds.size(), dense.speeds.size());
      for (size_t i = 0; i < dense.speeds.size(); ++i) {
        ASSERT_NEAR(state.speeds[i], dense.speeds[i], 1e-5) << "frame " << t << " value " << i;
      }
    }
  }
}

// The belief stays a distribution however long the session runs.
TEST_F(SequenceFilterTest, BeliefStaysNormalised) {
  const SequenceFilter filter = Filter();
  SequenceState state;
  for (int t = 0; t < 300; ++t) filter.Update(Frame((t * 7) % kLocations, 8), &state);
  const auto expect_distribution = [](const float* p, size_t n) {
    double total = 0;
    for (size_t i = 0; i < n; ++i) {
      ASSERT_TRUE(std::isfinite(p[i]));
      ASSERT_GE(p[i], 0.0f);
      total += p[i];
    }
    EXPECT_NEAR(total, 1.0, 1e-4);
  };
  expect_distribution(state.location.data(), state.location.size());
  const size_t speeds = static_cast<size_t>(filter.num_speeds());
  ASSERT_EQ(state.speeds.size(), (state.tracked.size() + 1) * speeds);
  for (size_t row = 0; row <= state.tracked.size(); ++row) {
    expect_distribution(state.speeds.data() + row * speeds, speeds);
  }
}

// The band the map suggests: the median track length (at least 2); the fastest speed either
// way defaults to twice it.
TEST_F(SequenceFilterTest, MotionBandFromTheMap) {
  const int band = SequenceFilter::MotionBand(map_);
  EXPECT_GE(band, 2);
  EXPECT_LE(band, 5);  // MakeRandomMap tracks span 2..5 images
  SequenceOptions automatic;
  const SequenceFilter filter(map_, automatic);
  EXPECT_EQ(filter.max_forward(), 2 * band);
  EXPECT_EQ(filter.max_backward(), 2 * band);
  EXPECT_EQ(filter.num_speeds(), 8 * band + 1);  // -2 band..2 band in half locations
  EXPECT_EQ(filter.num_tracked(), 64);           // the default
  EXPECT_EQ(SequenceFilter::StateValues(kLocations, 17, 64), 201u + 64 + 65 * 17);
}

// Settings out of range are refused with the setting's name.
TEST(SequenceOptionsTest, ValidateNamesTheSetting) {
  EXPECT_TRUE(SequenceOptions{}.Validate().ok());
  SequenceOptions o;
  o.evidence_weight = 0;
  EXPECT_NE(o.Validate().message().find("evidence_weight"), std::string::npos);
  o = {};
  o.jump = 1.5;
  EXPECT_NE(o.Validate().message().find("jump"), std::string::npos);
  o = {};
  o.max_forward = -2;
  EXPECT_NE(o.Validate().message().find("max_forward"), std::string::npos);
  o = {};
  o.tracked_locations = -1;
  EXPECT_NE(o.Validate().message().find("tracked_locations"), std::string::npos);
  o = {};
  o.speed_jump = -0.1;
  EXPECT_NE(o.Validate().message().find("speed_jump"), std::string::npos);
  o = {};
  o.leave = std::nan("");
  EXPECT_FALSE(o.Validate().ok());
}

}  // namespace
}  // namespace sceneloc
