// The evaluation of a map against queries (tools/eval/evaluation.h): the ground truth read
// from a CSV file and resolved to tour indices, the nearest-rank percentiles, the match
// rates at +-k on hand-built answers, and every method run on a map trained from a
// generated tour.
#include "tools/eval/evaluation.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "common/training/trainer.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

// Writes `text` to a CSV file of its own and reads it back as ground truth.
StatusOr<std::map<std::string, std::string>> ReadCsv(const test::ScratchDir& dir,
                                                     const std::string& text) {
  const std::string path = dir.File("truth.csv");
  test::WriteFileBytes(path, text);
  return ReadGroundTruth(path);
}

// Rows map query files to tour files; a header row (after any comments), comments, blank
// lines, spaces around the names and CRLF line ends are allowed.
TEST(GroundTruthTest, ReadsRowsSkippingHeaderAndComments) {
  const test::ScratchDir dir("eval");
  const std::map<std::string, std::string> expected = {{"q1.jpg", "t7.jpg"}, {"q2.jpg", "t3.jpg"}};
  for (const std::string text :
       {"query_file,tour_file\r\n# a comment\r\n\r\nq1.jpg,t7.jpg\r\nq2.jpg,t3.jpg\n",
        "# made by hand\n\nquery_file,tour_file\nq1.jpg, t7.jpg\n  q2.jpg ,t3.jpg  \n",
        "q1.jpg,t7.jpg\nq2.jpg,t3.jpg"}) {
    const auto truth = ReadCsv(dir, text);
    ASSERT_TRUE(truth.ok()) << truth.status().ToString();
    EXPECT_EQ(*truth, expected) << text;
  }
}

// A header-like row after the first is data, not a header: it names a query that is
// checked like any other. A query listed twice, or a row with an empty name, is refused
// with its line.
TEST(GroundTruthTest, RefusesRepeatedQueriesAndEmptyNames) {
  const test::ScratchDir dir("eval");
  const auto late_header = ReadCsv(dir, "q1.jpg,t1.jpg\nquery_file,tour_file\n");
  ASSERT_TRUE(late_header.ok());
  EXPECT_EQ(late_header->count("query_file"), 1u);
  for (const auto& [text, message] : std::vector<std::pair<std::string, std::string>>{
           {"q1.jpg,t1.jpg\nq2.jpg,t2.jpg\nq1.jpg,t9.jpg\n",
            ":3: query 'q1.jpg' is listed again (first on line 1)"},
           {"q1.jpg,t1.jpg\nq2.jpg, \n", ":2: an empty file name"},
           {",t1.jpg\n", ":1: an empty file name"}}) {
    const auto truth = ReadCsv(dir, text);
    ASSERT_FALSE(truth.ok()) << text;
    EXPECT_EQ(truth.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(truth.status().message().find(message), std::string::npos)
        << truth.status().message();
  }
}

// A missing file is NotFound; a row without exactly one comma is InvalidArgument naming
// the file and line; a file of no row is InvalidArgument.
TEST(GroundTruthTest, RejectsMissingFilesBadRowsAndEmptyFiles) {
  const test::ScratchDir dir("eval");
  EXPECT_EQ(ReadGroundTruth(dir.File("absent.csv")).status().code(), StatusCode::kNotFound);
  for (const std::string bad : {"q1.jpg;t1.jpg\n", "q1.jpg,t1.jpg,extra\n"}) {
    const auto truth = ReadCsv(dir, "q0.jpg,t0.jpg\n" + bad);
    ASSERT_FALSE(truth.ok()) << bad;
    EXPECT_EQ(truth.status().code(), StatusCode::kInvalidArgument);
    EXPECT_NE(truth.status().message().find(dir.File("truth.csv") + ":2:"), std::string::npos)
        << truth.status().message();
  }
  const auto header_only = ReadCsv(dir, "query_file,tour_file\n# nothing else\n");
  ASSERT_FALSE(header_only.ok());
  EXPECT_NE(header_only.status().message().find("has no row"), std::string::npos);
}

// The outcomes to fill must be one per query: anything else is refused before any work.
TEST(RunQueriesSizeTest, OutcomesMustMatchTheQueries) {
  const std::vector<FeatureSet> queries(3);
  std::vector<QueryOutcome> outcomes(2);
  const Status ours = RunOurs(queries, Map(), MatchOptions(), 1, &outcomes);
  EXPECT_EQ(ours.code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(ours.message(), "3 queries but 2 outcomes to fill");
  EXPECT_EQ(RunBaselines(queries, {}, 0.01, &outcomes).code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(RunOurs(queries, Map(), MatchOptions(), 1, nullptr).code(),
            StatusCode::kInvalidArgument);
}

// Without ground truth a query's truth is the tour image of its own name; with it, the
// named tour image. A query without a row, or a row naming no tour image, is NotFound.
TEST(GroundTruthTest, ResolvesToTourIndices) {
  const std::vector<std::string> tour = {"a.jpg", "b.jpg", "c.jpg"};
  const auto same_name = ResolveTruth({"c.jpg", "a.jpg"}, tour, {});
  ASSERT_TRUE(same_name.ok());
  EXPECT_EQ(*same_name, (std::vector<int>{2, 0}));
  const auto by_csv = ResolveTruth({"q1", "q2"}, tour, {{"q1", "b.jpg"}, {"q2", "b.jpg"}});
  ASSERT_TRUE(by_csv.ok());
  EXPECT_EQ(*by_csv, (std::vector<int>{1, 1}));
  const auto no_row = ResolveTruth({"q1", "q3"}, tour, {{"q1", "b.jpg"}});
  EXPECT_EQ(no_row.status().code(), StatusCode::kNotFound);
  EXPECT_NE(no_row.status().message().find("'q3'"), std::string::npos);
  const auto not_in_tour = ResolveTruth({"d.jpg"}, tour, {});
  EXPECT_EQ(not_in_tour.status().code(), StatusCode::kNotFound);
  EXPECT_NE(not_in_tour.status().message().find("'d.jpg' is not a tour image"), std::string::npos)
      << not_in_tour.status().message();
}

// Nearest-rank percentiles: the value at rank ceil(q * n), always an observed value, in any
// input order; zeros for no values.
TEST(PercentilesTest, NearestRank) {
  std::vector<double> hundred;
  for (int v = 100; v >= 1; --v) hundred.push_back(v);
  const Percentiles p = ComputePercentiles(hundred);
  EXPECT_EQ(p.median, 50);
  EXPECT_EQ(p.p90, 90);
  EXPECT_EQ(p.p99, 99);
  const Percentiles five = ComputePercentiles({5, 1, 4, 2, 3});
  EXPECT_EQ(five.median, 3);  // rank ceil(2.5) = 3
  EXPECT_EQ(five.p90, 5);
  const Percentiles one = ComputePercentiles({7.5});
  EXPECT_EQ(one.median, 7.5);
  EXPECT_EQ(one.p99, 7.5);
  const Percentiles none = ComputePercentiles({});
  EXPECT_EQ(none.median, 0);
  EXPECT_EQ(none.p99, 0);
}

// Each method names itself and reads its own answer of an outcome.
TEST(SummaryTest, MethodsNameAndSelectTheirOutcome) {
  const QueryOutcome o;
  EXPECT_EQ(&OutcomeOf(o, Method::kOurs), &o.ours);
  EXPECT_EQ(&OutcomeOf(o, Method::kBaseline), &o.baseline);
  EXPECT_EQ(&OutcomeOf(o, Method::kReranked), &o.reranked);
  EXPECT_STREQ(MethodName(Method::kOurs), "sceneloc");
  EXPECT_STREQ(MethodName(Method::kBaseline), "baseline");
  EXPECT_STREQ(MethodName(Method::kReranked), "baseline+ransac");
}

// Six hand-built answers 0, 1, 2, 3 and 10 frames off, and one unanswered query whose
// truth is location 0 (so -1 is one frame from it, and must still not count).
std::vector<QueryOutcome> HandBuiltOutcomes() {
  const int truth[] = {10, 10, 10, 10, 10, 0};
  const int predicted[] = {10, 11, 8, 13, 20, -1};
  const float confidence[] = {0.9f, 0.8f, 0.7f, 0.6f, 0.5f, 0.0f};
  std::vector<QueryOutcome> outcomes(6);
  for (int q = 0; q < 6; ++q) {
    outcomes[q].truth = truth[q];
    outcomes[q].ours = {predicted[q], confidence[q], 1.0 + q};
    outcomes[q].baseline = {truth[q], 0.5f, 10.0};  // always right
    outcomes[q].reranked = {-1, 0.0f, 20.0};        // never answers
    outcomes[q].extract_ms = 10.0 * (q + 1);
    outcomes[q].stages.descriptor_ms = 6.0 - q;
  }
  return outcomes;
}

// The rate at +-k is the share of queries answered within k frames; confidence, time and
// correctness at the judging tolerance come from the same answers.
TEST(SummaryTest, RatesAtEachToleranceOnHandBuiltAnswers) {
  const std::vector<QueryOutcome> outcomes = HandBuiltOutcomes();
  const MethodSummary m = SummariseMethod(outcomes, Method::kOurs, {1, 0.75});
  EXPECT_DOUBLE_EQ(m.match_rate[0], 1.0 / 6);
  EXPECT_DOUBLE_EQ(m.match_rate[1], 2.0 / 6);
  EXPECT_DOUBLE_EQ(m.match_rate[2], 3.0 / 6);
  EXPECT_DOUBLE_EQ(m.match_rate[3], 4.0 / 6);
  EXPECT_NEAR(m.mean_confidence, 3.5 / 6, 1e-6);
  // The lean: 0, +1, -2 and +3 frames off are near; 10 off and the unanswered are not.
  EXPECT_EQ(m.near_answers, 4);
  EXPECT_DOUBLE_EQ(m.lean, 0.5);
  EXPECT_EQ(m.match_ms.median, 3.0);  // of 1..6 ms
  EXPECT_EQ(m.match_ms.p90, 6.0);
  EXPECT_EQ(m.confidence.queries, 6);
  EXPECT_DOUBLE_EQ(m.confidence.accuracy, 2.0 / 6);  // within 1 frame
  EXPECT_EQ(m.confidence.threshold, 0.75);
  const MethodSummary tolerant = SummariseMethod(outcomes, Method::kOurs, {2, 0.75});
  EXPECT_DOUBLE_EQ(tolerant.confidence.accuracy, 3.0 / 6);
  EXPECT_DOUBLE_EQ(tolerant.match_rate[1], m.match_rate[1]);  // the rates do not depend on it
}

// Summarise fills the baselines only when they ran, and the time per stage.
TEST(SummaryTest, SummariseCoversTheMethodsThatRanAndTheStages) {
  const std::vector<QueryOutcome> outcomes = HandBuiltOutcomes();
  const EvalSummary with = Summarise(outcomes, true);
  EXPECT_EQ(with.queries, 6u);
  EXPECT_TRUE(with.has_baseline);
  EXPECT_DOUBLE_EQ(with.ours.match_rate[2], 3.0 / 6);
  EXPECT_DOUBLE_EQ(with.baseline.match_rate[0], 1.0);
  EXPECT_DOUBLE_EQ(with.reranked.match_rate[3], 0.0);
  EXPECT_EQ(with.extract_ms.median, 30.0);
  EXPECT_EQ(with.extract_ms.p99, 60.0);
  EXPECT_EQ(with.descriptor_ms.median, 3.0);
  const EvalSummary without = Summarise(outcomes, false);
  EXPECT_FALSE(without.has_baseline);
  EXPECT_EQ(without.baseline.match_rate[0], 0.0);
  EXPECT_EQ(without.baseline.confidence.queries, 0);
  const EvalSummary empty = Summarise({}, true);
  EXPECT_EQ(empty.queries, 0u);
  EXPECT_EQ(empty.ours.match_rate[3], 0.0);
  EXPECT_EQ(empty.ours.lean, 0.0);  // no near answers: no lean, not a division by zero
}

// A map trained from a generated tour and the test pass of the same route as queries.
class RunQueriesTest : public ::testing::Test {
 protected:
  static constexpr int kLocations = 6;

  static void SetUpTestSuite() {
    TrainOptions train;
    train.extractor.working_size = 320;  // the generated frames' own size
    tour_ = new std::vector<FeatureSet>(
        test::ExtractTourPass(test::SmallTour(kLocations), kTrainingPass, train.extractor));
    const ExtractionTarget frame = test::MapFrameOf(*tour_);
    queries_ = new std::vector<FeatureSet>(
        test::ExtractTourPass(test::SmallTour(kLocations), kTestPass, train.extractor, &frame));
    std::vector<std::string> names;
    for (int i = 0; i < kLocations; ++i) names.push_back(TourImageName(i));
    auto trained = TrainFromFeatures(*tour_, names, train, 2, nullptr);
    ASSERT_TRUE(trained.ok()) << trained.status().ToString();
    map_ = new Map(std::move(trained->map));
  }
  static void TearDownTestSuite() {
    delete map_;
    delete queries_;
    delete tour_;
  }
  void SetUp() override { ASSERT_NE(map_, nullptr); }

  static std::vector<QueryOutcome> Outcomes() {
    std::vector<QueryOutcome> outcomes(kLocations);
    for (int q = 0; q < kLocations; ++q) outcomes[q].truth = q;
    return outcomes;
  }

  static std::vector<FeatureSet>* tour_;
  static std::vector<FeatureSet>* queries_;
  static Map* map_;
};
std::vector<FeatureSet>* RunQueriesTest::tour_ = nullptr;
std::vector<FeatureSet>* RunQueriesTest::queries_ = nullptr;
Map* RunQueriesTest::map_ = nullptr;

// Every query gets our answer with what it was based on, and both baselines' answers; the
// re-ranked baseline's time includes the vote's. Most answers are within a frame.
TEST_F(RunQueriesTest, FillsEveryMethodsAnswer) {
  std::vector<QueryOutcome> outcomes = Outcomes();
  ASSERT_TRUE(RunQueries(*queries_, *map_, MatchOptions(), 2, tour_, &outcomes).ok());
  int ours_right = 0, baseline_right = 0;
  for (int q = 0; q < kLocations; ++q) {
    SCOPED_TRACE("query " + std::to_string(q));
    const QueryOutcome& o = outcomes[q];
    EXPECT_EQ(o.truth, q);
    EXPECT_GE(o.ours.predicted, -1);
    EXPECT_LT(o.ours.predicted, kLocations);
    EXPECT_GE(o.ours.confidence, 0.0f);
    EXPECT_LE(o.ours.confidence, 1.0f);
    EXPECT_GT(o.ours.ms, 0.0);
    EXPECT_EQ(o.keypoints, (*queries_)[q].size());
    EXPECT_EQ(o.location_scores.size(), static_cast<size_t>(kLocations));
    EXPECT_GE(o.in_map, 0.0);
    EXPECT_LE(o.in_map, 1.0);
    EXPECT_GT(o.descriptor_matches, 0u);
    EXPECT_GE(o.baseline.predicted, 0);
    EXPECT_LT(o.baseline.predicted, kLocations);
    EXPECT_GE(o.reranked.ms, o.baseline.ms);
    ours_right += o.ours.predicted >= 0 && std::abs(o.ours.predicted - q) <= 1;
    baseline_right += std::abs(o.baseline.predicted - q) <= 1;
  }
  EXPECT_GT(ours_right, kLocations / 2);
  EXPECT_GT(baseline_right, kLocations / 2);
}

// Without a baseline tour only ours runs; a baseline tour without a feature is an error.
TEST_F(RunQueriesTest, BaselinesRunOnlyWithATour) {
  std::vector<QueryOutcome> outcomes = Outcomes();
  ASSERT_TRUE(RunQueries(*queries_, *map_, MatchOptions(), 1, nullptr, &outcomes).ok());
  for (const QueryOutcome& o : outcomes) {
    EXPECT_EQ(o.baseline.predicted, -1);
    EXPECT_EQ(o.reranked.predicted, -1);
  }
  const std::vector<FeatureSet> featureless(2);
  const Status status = RunQueries(*queries_, *map_, MatchOptions(), 1, &featureless, &outcomes);
  EXPECT_EQ(status.code(), StatusCode::kFailedPrecondition) << status.ToString();
}

}  // namespace
}  // namespace sceneloc
