// Leave-one-set-out (tools/eval/leave_one_out.h) on real answers: a map trained from a
// generated tour, its test pass localised, the answers read again with other constants.
#include "tools/eval/leave_one_out.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "common/training/trainer.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 16;

class LeaveOneOutTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    TrainOptions train;
    train.extractor.working_size = 320;  // the generated frames' own size
    const std::vector<FeatureSet> tour =
        test::ExtractTourPass(test::SmallTour(kLocations), kTrainingPass, train.extractor);
    const ExtractionTarget frame = test::MapFrameOf(tour);
    const std::vector<FeatureSet> queries =
        test::ExtractTourPass(test::SmallTour(kLocations), kTestPass, train.extractor, &frame);
    std::vector<std::string> names;
    for (int i = 0; i < kLocations; ++i) names.push_back(TourImageName(i));
    auto trained = TrainFromFeatures(tour, names, train, 2, nullptr);
    ASSERT_TRUE(trained.ok()) << trained.status().ToString();
    shell_ = new Map(MapShell(trained->map));
    outcomes_ = new std::vector<QueryOutcome>(kLocations);
    for (int q = 0; q < kLocations; ++q) (*outcomes_)[q].truth = q;
    ASSERT_TRUE(RunOurs(queries, trained->map, MatchOptions(), 2, outcomes_).ok());
  }
  static void TearDownTestSuite() {
    delete shell_;
    delete outcomes_;
  }
  void SetUp() override { ASSERT_NE(shell_, nullptr); }

  static Map* shell_;
  static std::vector<QueryOutcome>* outcomes_;
};
Map* LeaveOneOutTest::shell_ = nullptr;
std::vector<QueryOutcome>* LeaveOneOutTest::outcomes_ = nullptr;

// The map's own constants read every answer as Localise gave it; a hotter posterior makes
// the answers less sure of themselves; the shell holds no landmarks.
TEST_F(LeaveOneOutTest, TheShippedConstantsReadTheAnswersAsGiven) {
  EXPECT_EQ(shell_->num_landmarks(), 0);
  const std::vector<MethodOutcome> same =
      ReadWithConstants(*shell_, MatchOptions(), *outcomes_, ConstantsOf(shell_->options));
  ASSERT_EQ(same.size(), outcomes_->size());
  double sure = 0, hot_sure = 0;
  ConfidenceConstants hot = ConstantsOf(shell_->options);
  hot.temperature *= 4;
  const std::vector<MethodOutcome> hotter =
      ReadWithConstants(*shell_, MatchOptions(), *outcomes_, hot);
  for (size_t q = 0; q < same.size(); ++q) {
    EXPECT_EQ(same[q].predicted, (*outcomes_)[q].ours.predicted) << q;
    EXPECT_NEAR(same[q].confidence, (*outcomes_)[q].ours.confidence, 1e-6) << q;
    sure += same[q].confidence;
    hot_sure += hotter[q].confidence;
  }
  EXPECT_LT(hot_sure, sure);
}

// The shell keeps what the confidence and a session read besides the calibration: the
// look-alikes (a map of a repetitive building is read as less sure) and the landmarks'
// observation counts (the session's motion band).
TEST(MapShellTest, KeepsTheLookAlikesAndTheObservationCounts) {
  Map map;
  map.image_names = {"a.jpg", "b.jpg", "c.jpg"};
  map.lookalike_offsets = {0, 1, 1, 2};
  map.lookalike_location = {2, 0};
  map.lookalike_ratio = {0.9f, 0.9f};
  map.observation_offsets = {0, 3, 5};
  const Map shell = MapShell(map);
  EXPECT_EQ(shell.image_names, map.image_names);
  EXPECT_EQ(shell.lookalike_offsets, map.lookalike_offsets);
  EXPECT_EQ(shell.lookalike_location, map.lookalike_location);
  EXPECT_EQ(shell.lookalike_ratio, map.lookalike_ratio);
  EXPECT_EQ(shell.observation_offsets, map.observation_offsets);
  EXPECT_TRUE(shell.has_lookalikes());
}

// From a start far too hot, on answers nearly all right, the fit cools the posterior.
TEST_F(LeaveOneOutTest, TheFitImprovesOnAPoorStart) {
  const HeldOutInput set{"generated", "generated", shell_, outcomes_};
  ConfidenceConstants poor = ConstantsOf(shell_->options);
  poor.temperature *= 8;
  const ConfidenceConstants fitted = FitConstants({set}, MatchOptions(), Judging(), poor);
  EXPECT_LT(fitted.temperature, poor.temperature);
  EXPECT_EQ(FitConstants({}, MatchOptions(), Judging(), poor).temperature, poor.temperature);
}

// Each set is held out with its family: two sets of one family leave nothing to fit on and
// keep the shipped constants; a set of another family is fitted on the first two.
TEST_F(LeaveOneOutTest, SetsAreHeldOutWithTheirFamily) {
  // Set c's session: every answer one location further on at confidence 0.97 (right within
  // the tolerance but not exact); set a has none.
  std::vector<MethodOutcome> session;
  for (const QueryOutcome& o : *outcomes_) session.push_back({o.truth + 1, 0.97f});
  session.back() = {(*outcomes_).back().truth - 9, 0.995f};  // one gross error at >= 0.99
  const std::vector<HeldOutInput> sets = {{"a", "day", shell_, outcomes_},
                                          {"b", "day", shell_, outcomes_},
                                          {"c", "night", shell_, outcomes_, &session}};
  const std::vector<HeldOutSummary> held = LeaveOneSetOut(sets, MatchOptions(), Judging());
  ASSERT_EQ(held.size(), 3u);
  const ConfidenceConstants shipped = ConstantsOf(shell_->options);
  const ConfidenceConstants fitted_on_day =
      FitConstants({sets[0], sets[1]}, MatchOptions(), Judging(), shipped);
  EXPECT_EQ(held[2].fitted.temperature, fitted_on_day.temperature);
  EXPECT_EQ(held[2].fitted.offset, fitted_on_day.offset);
  const ConfidenceConstants fitted_on_night =
      FitConstants({sets[2]}, MatchOptions(), Judging(), shipped);
  EXPECT_EQ(held[0].fitted.slope, fitted_on_night.slope);
  EXPECT_EQ(held[0].summary.confidence.queries, kLocations);
  EXPECT_EQ(held[0].shipped.match_rate[2], held[0].summary.match_rate[2]);
  EXPECT_EQ(held[0].confidence.size(), static_cast<size_t>(kLocations));
  EXPECT_FALSE(held[0].has_session);
  ASSERT_TRUE(held[2].has_session);
  EXPECT_EQ(held[2].session_accepted_95, kLocations);
  EXPECT_EQ(held[2].session_right_95, kLocations - 1);
  EXPECT_EQ(held[2].session_gross_99, 1);
  EXPECT_DOUBLE_EQ(held[2].session.match_rate[0], 0.0);
  EXPECT_DOUBLE_EQ(held[2].session.match_rate[1], (kLocations - 1.0) / kLocations);
  const nlohmann::json json = LeaveOneOutJson(held, 0.8);
  EXPECT_EQ(json["sets"].size(), 3u);
  EXPECT_FALSE(json["sets"][0].contains("session"));
  EXPECT_EQ(json["sets"][2]["session"]["gross_99"], 1);
  EXPECT_EQ(PooledHeldOut(held, 0.8).queries, 3 * kLocations);
}

}  // namespace
}  // namespace sceneloc
