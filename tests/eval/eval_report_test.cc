// sceneloc-eval's report (tools/eval/eval_report.h): the JSON file's fields and the
// printed table and answer lines, on figures made in code.
#include "tools/eval/eval_report.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/test_map.h"

namespace sceneloc {
namespace {

// Three queries: right, one frame off, and unanswered.
std::vector<QueryOutcome> ThreeOutcomes() {
  std::vector<QueryOutcome> outcomes(3);
  const char* names[] = {"q0.jpg", "q1.jpg", "q2.jpg"};
  for (int q = 0; q < 3; ++q) {
    outcomes[q].name = names[q];
    outcomes[q].truth = q;
  }
  outcomes[0].ours = {0, 0.95f, 2.0};
  outcomes[1].ours = {2, 0.40f, 3.0};
  outcomes[2].ours = {-1, 0.0f, 1.0};
  return outcomes;
}

class EvalReportTest : public ::testing::Test {
 protected:
  EvalReportTest() : map_(test::MakeRandomMap(4, 30, 8)), outcomes_(ThreeOutcomes()) {
    summary_ = Summarise(outcomes_, false);
    report_.map_path = "lab.scnl";
    report_.queries_dir = "queries/";
    report_.threads = 2;
    report_.summary = &summary_;
    report_.outcomes = &outcomes_;
    report_.map = &map_;
    report_.options = &options_;
  }

  Map map_;
  MatchOptions options_;
  std::vector<QueryOutcome> outcomes_;
  EvalSummary summary_;
  EvalReport report_;
};

// The JSON holds the match rates by tolerance, the query count and one entry per query;
// the baselines and negatives only when they ran.
TEST_F(EvalReportTest, JsonHoldsTheFiguresThatRan) {
  const nlohmann::json j = ReportJson(report_);
  EXPECT_EQ(j["queries"], 3);
  EXPECT_DOUBLE_EQ(j["match_rate"]["0"].get<double>(), summary_.ours.match_rate[0]);
  EXPECT_DOUBLE_EQ(j["match_rate"]["2"].get<double>(), summary_.ours.match_rate[2]);
  ASSERT_EQ(j["per_query"].size(), 3u);
  EXPECT_EQ(j["per_query"][1]["query"], "q1.jpg");
  EXPECT_EQ(j["per_query"][1]["predicted"], 2);
  EXPECT_EQ(j["per_query"][2]["predicted"], -1);
  EXPECT_FALSE(j.contains("baseline"));
  EXPECT_FALSE(j.contains("negatives"));
  EXPECT_FALSE(j.contains("session"));
  EXPECT_FALSE(j["per_query"][0].contains("baseline_predicted"));

  const Negatives negatives{10, 2, 0.9f};
  report_.negatives = &negatives;
  const nlohmann::json with = ReportJson(report_);
  EXPECT_EQ(with["negatives"]["frames"], 10);
  EXPECT_EQ(with["negatives"]["accepted"], 2);
}

// A session adds its single-frame figures (alone and in the session), its relocalisation
// counts (for a kidnap) and each query's single-frame answer.
TEST_F(EvalReportTest, JsonAddsTheSession) {
  SequenceRun run;
  run.relocalisation.to_correct = {1, 3};
  run.relocalisation.to_localised = {2, 4};
  std::vector<QueryOutcome> single = ThreeOutcomes();
  single[1].ours.predicted = 1;
  std::vector<QueryOutcome> in_session = ThreeOutcomes();
  in_session[0].ours.predicted = 3;  // none exact, where single has two
  const SessionReport session{SummariseMethod(single, Method::kOurs),
                              SummariseMethod(in_session, Method::kOurs), &run, single, 2};
  report_.session = &session;
  const nlohmann::json j = ReportJson(report_);
  EXPECT_DOUBLE_EQ(j["session"]["in_session"]["match_rate"]["0"].get<double>(),
                   session.in_session.match_rate[0]);
  EXPECT_NE(session.in_session.match_rate[0], session.single.match_rate[0]);
  EXPECT_EQ(j["session"]["kidnap_segments"], 2);
  EXPECT_EQ(j["session"]["frames_to_correct"]["per_jump"], (std::vector<int>{1, 3}));
  EXPECT_EQ(j["session"]["frames_to_localised"]["max"], 4);
  EXPECT_EQ(j["per_query"][1]["single_predicted"], 1);
  EXPECT_EQ(j["per_query"][1]["predicted"], 2);
}

// Each answer line says where the query went, LOCALISED or UNKNOWN at the threshold, and
// ok or MISS at the tolerance; an unanswered query says so.
TEST_F(EvalReportTest, AnswerLinesJudgeEachQuery) {
  const std::vector<std::string> tour = {"t0.jpg", "t1.jpg", "t2.jpg", "t3.jpg"};
  ::testing::internal::CaptureStdout();
  PrintAnswers(outcomes_, tour, 0, 0.5);
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("tour location   0 (t0.jpg), confidence 0.95 LOCALISED [truth 0, ok]"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("tour location   2 (t2.jpg), confidence 0.40 UNKNOWN   [truth 1, MISS]"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("q2.jpg           -> no answer"), std::string::npos) << out;
}

// The table names the map and the queries, has a row per method that ran, and the
// negatives' line when they ran.
TEST_F(EvalReportTest, TableShowsWhatRan) {
  const Negatives negatives{10, 2, 0.9f};
  report_.negatives = &negatives;
  report_.negatives_dir = "elsewhere/";
  ::testing::internal::CaptureStdout();
  PrintReport(report_);
  const std::string out = ::testing::internal::GetCapturedStdout();
  EXPECT_NE(out.find("map lab.scnl: 4 locations, 30 landmarks"), std::string::npos) << out;
  EXPECT_NE(out.find("3 queries from queries/, 2 matching thread(s)"), std::string::npos) << out;
  EXPECT_NE(out.find("\nsceneloc "), std::string::npos) << out;
  EXPECT_EQ(out.find("\nbaseline "), std::string::npos) << out;
  EXPECT_NE(out.find("negatives: 10 frames from elsewhere/, 2 LOCALISED (20.0%)"),
            std::string::npos)
      << out;
  EXPECT_EQ(out.find("session:"), std::string::npos) << out;
}

}  // namespace
}  // namespace sceneloc
