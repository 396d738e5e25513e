// The accuracy suite (tools/eval/accuracy_suite.h): which development sets a data folder
// holds, the ablation variants as settings files read them, and sets, generated query
// variants and whole suite runs on folders of generated tour JPEGs.
#include "tools/eval/accuracy_suite.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "common/config/config.h"
#include "common/synthetic/tour_generator.h"
#include "common/util/image_folder.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/tour_features.h"
#include "tools/eval/distractor_suite.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

// A set of hand-made outcomes: (truth, our answer, our confidence) per query; the baselines
// answer each query one frame off.
SetResult HandMadeSet(QueryChange change, const std::vector<std::tuple<int, int, float>>& queries) {
  SetResult r;
  r.set.change = change;
  for (const auto& [truth, predicted, confidence] : queries) {
    QueryOutcome o;
    o.truth = truth;
    o.ours.predicted = predicted;
    o.ours.confidence = confidence;
    o.baseline.predicted = truth + 1;
    o.baseline.confidence = 0.5f;
    o.reranked = o.baseline;
    r.outcomes.push_back(o);
  }
  return r;
}

// Pooling keeps each query with its own set's truth, leaves out changed sets when asked, and
// of one set gives that set's own summary.
TEST(AccuracySuiteTest, PooledSummaryJudgesEachQueryAgainstItsOwnSet) {
  const SetResult real = HandMadeSet(
      QueryChange::kNone, {{10, 10, 0.9f}, {20, 21, 0.8f}, {30, 50, 0.3f}, {40, 40, 0.7f}});
  // The same truths' answers would be wrong against the first set's.
  const SetResult darker = HandMadeSet(QueryChange::kDarker, {{5, 5, 0.6f}, {7, 90, 0.4f}});
  const Judging judging{2, 0.5};

  const EvalSummary unchanged = PooledSummary({real, darker}, /*unchanged_only=*/true, judging);
  EXPECT_EQ(unchanged.queries, 4u);
  EXPECT_DOUBLE_EQ(unchanged.ours.match_rate[2], 0.75);
  EXPECT_DOUBLE_EQ(unchanged.ours.match_rate[0], 0.5);
  EXPECT_EQ(unchanged.ours.confidence.queries, 4);
  EXPECT_DOUBLE_EQ(unchanged.ours.confidence.correct_accepted, 1.0);  // 3 of 3 right accepted
  EXPECT_DOUBLE_EQ(unchanged.baseline.match_rate[0], 0.0);
  EXPECT_DOUBLE_EQ(unchanged.baseline.match_rate[1], 1.0);

  const EvalSummary all = PooledSummary({real, darker}, /*unchanged_only=*/false, judging);
  EXPECT_EQ(all.queries, 6u);
  EXPECT_DOUBLE_EQ(all.ours.match_rate[2], 4.0 / 6);
  EXPECT_EQ(all.ours.confidence.queries, 6);
  EXPECT_DOUBLE_EQ(all.ours.confidence.accepted_precision, 1.0);  // .9 .8 .7 .6, all right

  // A generated tour is not a real set, though its query frames are its own.
  SetResult street = HandMadeSet(QueryChange::kNone, {{3, 3, 0.9f}});
  street.set.generated = TourOptions();
  EXPECT_EQ(PooledSummary({real, street}, /*unchanged_only=*/true, judging).queries, 4u);
  EXPECT_EQ(PooledSummary({real, street}, /*unchanged_only=*/false, judging).queries, 5u);

  const EvalSummary one = PooledSummary({real}, /*unchanged_only=*/false, judging);
  const EvalSummary own = Summarise(real.outcomes, /*with_baseline=*/true, judging);
  EXPECT_DOUBLE_EQ(one.ours.confidence.pr_auc, own.ours.confidence.pr_auc);
  EXPECT_DOUBLE_EQ(one.ours.confidence.ece, own.ours.confidence.ece);
  EXPECT_EQ(PooledSummary({}, false, judging).queries, 0u);
}

// Each change has its own name, as the reports print it.
TEST(AccuracySuiteTest, QueryChangesHaveTheirNames) {
  EXPECT_STREQ(QueryChangeName(QueryChange::kNone), "none");
  EXPECT_STREQ(QueryChangeName(QueryChange::kSmaller), "smaller");
  EXPECT_STREQ(QueryChangeName(QueryChange::kDarker), "darker");
  EXPECT_STREQ(QueryChangeName(QueryChange::kJpeg), "jpeg");
  EXPECT_STREQ(QueryChangeName(QueryChange::kBlur), "blur");
  EXPECT_STREQ(QueryChangeName(QueryChange::kZoom), "zoom");
  EXPECT_STREQ(QueryChangeName(QueryChange::kSensor43), "sensor_4_3");
  EXPECT_STREQ(QueryChangeName(QueryChange::kRoll), "roll");
}

std::vector<std::string> SetNames(const std::vector<SuiteSet>& sets) {
  std::vector<std::string> names;
  for (const SuiteSet& s : sets) names.push_back(s.name);
  return names;
}

// Makes every folder of ../shared/data under `data` (empty); returns its path.
std::string FullDataFolder(const test::ScratchDir& data) {
  for (const char* d : {"gardens_point/day_left", "gardens_point/day_right",
                        "gardens_point/night_right", "corridor/ref", "corridor/query"}) {
    fs::create_directories(data.path() / d);
  }
  return data.path().string();
}

// With every folder present: all eleven sets in order, the generated variants over the
// Gardens Point day queries, and the other data set's folders as negatives; then the
// generated look-alike street, with every real folder as its negatives.
TEST(AccuracySuiteTest, DevelopmentSuiteOfAFullDataFolder) {
  const test::ScratchDir data("suite");
  const std::string root = FullDataFolder(data);
  const std::vector<SuiteSet> sets = DevelopmentSuite(root);
  EXPECT_EQ(SetNames(sets), (std::vector<std::string>{
                                "gp_day", "gp_night_same", "gp_night_other", "corridor",
                                "gp_day_smaller", "gp_day_darker", "gp_day_jpeg", "gp_day_blur",
                                "gp_day_zoom", "gp_day_4_3", "gp_day_roll", "lookalike_street"}));
  ASSERT_EQ(sets.size(), 12u);
  EXPECT_EQ(sets[11].negative_dirs.size(), 5u);
  ASSERT_TRUE(sets[11].generated.has_value());
  EXPECT_GT(sets[11].generated->repeat_blocks, 0);
  EXPECT_TRUE(sets[11].generated->Validate().ok());
  for (int i = 0; i < 11; ++i) EXPECT_FALSE(sets[i].generated.has_value()) << sets[i].name;
  EXPECT_EQ(sets[0].tour_dir, root + "/gardens_point/day_left");
  EXPECT_EQ(sets[0].queries_dir, root + "/gardens_point/day_right");
  EXPECT_EQ(sets[0].negative_dirs,
            (std::vector<std::string>{root + "/corridor/ref", root + "/corridor/query"}));
  EXPECT_EQ(sets[1].tour_limit, 100);
  EXPECT_EQ(sets[3].negative_dirs.size(), 3u);
  const QueryChange changes[] = {
      QueryChange::kSmaller, QueryChange::kDarker,   QueryChange::kJpeg, QueryChange::kBlur,
      QueryChange::kZoom,    QueryChange::kSensor43, QueryChange::kRoll};
  for (int i = 0; i < 7; ++i) {
    EXPECT_EQ(sets[4 + i].change, changes[i]) << sets[4 + i].name;
    EXPECT_EQ(sets[4 + i].queries_dir, sets[0].queries_dir);
  }
}

// The swapped sets: each real set's tour and queries the other way round, cut to the
// frames both walks have, with the other data set's frames as negatives.
TEST(AccuracySuiteTest, SwappedSuiteOfAFullDataFolder) {
  const test::ScratchDir data("suite");
  const std::string root = FullDataFolder(data);
  const std::vector<SuiteSet> sets = SwappedSuite(root);
  EXPECT_EQ(SetNames(sets),
            (std::vector<std::string>{"gp_day_swapped", "gp_night_swapped", "corridor_swapped"}));
  ASSERT_EQ(sets.size(), 3u);
  EXPECT_EQ(sets[0].tour_dir, root + "/gardens_point/day_right");
  EXPECT_EQ(sets[0].queries_dir, root + "/gardens_point/day_left");
  EXPECT_EQ(sets[0].query_limit, 100);  // day_left has 200, day_right's tour 100
  EXPECT_EQ(sets[1].tour_dir, root + "/gardens_point/night_right");
  EXPECT_EQ(sets[1].queries_dir, root + "/gardens_point/day_right");
  EXPECT_EQ(sets[2].tour_dir, root + "/corridor/query");
  EXPECT_EQ(sets[2].queries_dir, root + "/corridor/ref");
  EXPECT_EQ(sets[2].query_limit, 55);  // ref has 111, query's tour 55
  EXPECT_EQ(sets[0].negative_dirs,
            (std::vector<std::string>{root + "/corridor/ref", root + "/corridor/query"}));
  EXPECT_EQ(sets[2].negative_dirs.size(), 3u);
  for (const SuiteSet& s : sets) EXPECT_EQ(s.change, QueryChange::kNone) << s.name;
  // None of them is a development set: the default run leaves them out.
  for (const SuiteSet& d : DevelopmentSuite(root)) {
    for (const SuiteSet& s : sets) EXPECT_NE(d.name, s.name);
  }
}

// Sets whose folders are missing are left out, and so are missing negative folders; the
// generated set needs no folder.
TEST(AccuracySuiteTest, DevelopmentSuiteLeavesOutWhatIsMissing) {
  const test::ScratchDir data("suite");
  EXPECT_EQ(SetNames(DevelopmentSuite(data.File("absent"))),
            (std::vector<std::string>{"lookalike_street"}));
  fs::create_directories(data.path() / "gardens_point/day_left");
  fs::create_directories(data.path() / "gardens_point/day_right");
  const std::vector<SuiteSet> sets = DevelopmentSuite(data.path().string());
  EXPECT_EQ(SetNames(sets),
            (std::vector<std::string>{"gp_day", "gp_day_smaller", "gp_day_darker", "gp_day_jpeg",
                                      "gp_day_blur", "gp_day_zoom", "gp_day_4_3", "gp_day_roll",
                                      "lookalike_street"}));
  for (const SuiteSet& s : sets) {
    if (s.generated) continue;
    EXPECT_TRUE(s.negative_dirs.empty()) << s.name;
  }
  EXPECT_EQ(sets.back().negative_dirs,
            (std::vector<std::string>{data.path().string() + "/gardens_point/day_left",
                                      data.path().string() + "/gardens_point/day_right"}));
  EXPECT_EQ(SetNames(SwappedSuite(data.path().string())),
            (std::vector<std::string>{"gp_day_swapped"}));
}

// Every ablation variant has its own name and reads as settings files do; the first is our
// defaults, and each other either takes the paper's settings or changes a setting.
TEST(AccuracySuiteTest, AblationVariantsAreValidSettings) {
  const std::vector<AblationVariant> variants = AblationVariants();
  ASSERT_FALSE(variants.empty());
  EXPECT_EQ(variants[0].name, "default");
  EXPECT_TRUE(variants[0].train_yaml.empty() && variants[0].match_yaml.empty());
  std::set<std::string> names;
  const std::string train_default = TrainOptionsToYaml(TrainOptions());
  const std::string match_default = MatchOptionsToYaml(MatchOptions());
  for (const AblationVariant& v : variants) {
    SCOPED_TRACE(v.name);
    EXPECT_TRUE(names.insert(v.name).second) << "a second variant of this name";
    if (v.train_yaml == "@paper" || v.match_yaml == "@paper") continue;
    TrainOptions train;
    MatchOptions match;
    ASSERT_TRUE(ParseTrainOptions(v.train_yaml, v.name, &train).ok());
    ASSERT_TRUE(ParseMatchOptions(v.match_yaml, v.name, &match).ok());
    const bool changes =
        TrainOptionsToYaml(train) != train_default || MatchOptionsToYaml(match) != match_default;
    EXPECT_EQ(changes, v.name != "default");
  }
}

// Folders of generated JPEGs: a tour, the test pass of the same route (truth: the same
// file name) and frames of another scene (negatives).
constexpr int kLocations = 5;

class SuiteRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    set_.name = "generated";
    set_.tour_dir = dir_.File("tour");
    set_.queries_dir = dir_.File("queries");
    ASSERT_TRUE(WriteTour(test::SmallTour(kLocations), set_.tour_dir, kTrainingPass).ok());
    ASSERT_TRUE(WriteTour(test::SmallTour(kLocations), set_.queries_dir, kTestPass).ok());
    context_.cache_dir = dir_.File("cache");
    context_.threads = 2;
    extractor_.working_size = 320;  // the generated frames' own size
  }

  const test::ScratchDir dir_{"suite"};
  SuiteSet set_;
  SuiteContext context_;
  ExtractorOptions extractor_;
};

// A set's features with the truth by file name; the limits take the first images; a second
// load reads the same features from the cache.
TEST_F(SuiteRunTest, LoadSetExtractsWithTruthByName) {
  set_.tour_limit = 4;
  set_.query_limit = 3;
  const auto data = LoadSet(set_, extractor_, context_);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  EXPECT_EQ(data->tour.size(), 4u);
  EXPECT_EQ(data->queries.size(), 3u);
  EXPECT_EQ(data->truth, (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(data->query_names[2], TourImageName(2));
  EXPECT_EQ(data->extractor.working_size, 320);
  for (const FeatureSet& q : data->queries) EXPECT_EQ(q.image_width, data->tour[0].image_width);
  const auto again = LoadSet(set_, extractor_, context_);
  ASSERT_TRUE(again.ok());
  for (size_t i = 0; i < 3; ++i) test::ExpectFeatureSetsEqual(again->queries[i], data->queries[i]);

  set_.tour_limit = 2;  // query 2's tour image is not in the map
  const auto missing = LoadSet(set_, extractor_, context_);
  EXPECT_EQ(missing.status().code(), StatusCode::kNotFound);
}

// A generated set is rendered into the cache once (tour and test pass, truth by file name),
// read from there again, rendered again when its options change, and needs a cache.
TEST_F(SuiteRunTest, AGeneratedSetIsRenderedIntoTheCacheOnce) {
  SuiteSet generated;
  generated.name = "street";
  generated.generated = test::SmallTour(kLocations);
  generated.generated->repeat_blocks = 1;
  const auto data = LoadSet(generated, extractor_, context_);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  EXPECT_EQ(data->tour.size(), static_cast<size_t>(kLocations));
  EXPECT_EQ(data->truth, (std::vector<int>{0, 1, 2, 3, 4}));
  const fs::path first = fs::path(context_.cache_dir) / "generated/street/test" / TourImageName(0);
  ASSERT_TRUE(fs::is_regular_file(first));
  const auto written = fs::last_write_time(first);
  fs::last_write_time(first, written - std::chrono::hours(1));
  ASSERT_TRUE(LoadSet(generated, extractor_, context_).ok());
  EXPECT_EQ(fs::last_write_time(first), written - std::chrono::hours(1));  // not rendered again

  generated.generated->repeat_blocks = 0;
  ASSERT_TRUE(LoadSet(generated, extractor_, context_).ok());
  EXPECT_NE(fs::last_write_time(first), written - std::chrono::hours(1));  // rendered again

  SuiteContext no_cache = context_;
  no_cache.cache_dir.clear();
  EXPECT_EQ(LoadSet(generated, extractor_, no_cache).status().code(), StatusCode::kInvalidArgument);
  generated.generated->num_locations = 0;
  EXPECT_EQ(LoadSet(generated, extractor_, context_).status().code(), StatusCode::kInvalidArgument);
}

// Where LoadSet writes the generated variant of query `i` of `set`.
fs::path VariantPath(const SuiteSet& set, const SuiteContext& context, int i) {
  return fs::path(context.cache_dir) / "variants" / (set.name + "_" + std::to_string(kLocations)) /
         TourImageName(i);
}

double Sharpness(const cv::Mat& image) {
  cv::Mat grey, laplacian;
  cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  cv::Laplacian(grey, laplacian, CV_64F);
  cv::Scalar mean, stddev;
  cv::meanStdDev(laplacian, mean, stddev);
  return stddev[0];
}

// Each change is written once as JPEG files under the cache, and the changed queries are
// extracted in the map's frame: a third of the size, darker, blurred, more compressed, or
// seen through a narrower lens, a 4:3 sensor or a rolled camera.
TEST_F(SuiteRunTest, GeneratedVariantsChangeTheQueries) {
  const std::string query = set_.queries_dir + "/" + TourImageName(1);
  const cv::Mat original = cv::imread(query);
  ASSERT_FALSE(original.empty());
  // Loads the set with `change` and decodes its variant of query 1.
  const auto load = [&](QueryChange change) {
    set_.change = change;
    set_.name = QueryChangeName(change);
    const auto data = LoadSet(set_, extractor_, context_);
    EXPECT_TRUE(data.ok()) << data.status().ToString();
    if (data.ok()) {
      EXPECT_EQ(data->queries[1].image_width, data->tour[0].image_width);
    }
    return cv::imread(VariantPath(set_, context_, 1).string());
  };
  const cv::Mat smaller = load(QueryChange::kSmaller);
  EXPECT_EQ(smaller.cols, cvRound(original.cols / 3.0));
  EXPECT_EQ(smaller.rows, cvRound(original.rows / 3.0));
  EXPECT_LT(cv::mean(load(QueryChange::kDarker))[1], 0.5 * cv::mean(original)[1]);
  EXPECT_LT(Sharpness(load(QueryChange::kBlur)), 0.5 * Sharpness(original));
  EXPECT_EQ(load(QueryChange::kZoom).size(),
            cv::Size(original.cols * 8 / 10, original.rows * 8 / 10));
  EXPECT_EQ(load(QueryChange::kSensor43).size(), cv::Size(original.rows * 4 / 3, original.rows));
  EXPECT_EQ(load(QueryChange::kRoll).size(),
            cv::Size(original.cols * 10 / 12, original.rows * 10 / 12));
  EXPECT_EQ(load(QueryChange::kJpeg).size(), original.size());
  EXPECT_LT(fs::file_size(VariantPath(set_, context_, 1)), fs::file_size(query));

  // Written once: a variant already there, made from the source as it is, is used as it is.
  const std::string variant = VariantPath(set_, context_, 1).string();
  const std::string kept = test::ReadFileBytes(query);
  test::WriteFileBytes(variant, kept);
  load(QueryChange::kJpeg);
  EXPECT_EQ(test::ReadFileBytes(variant), kept);
  // A source changed since (here only touched: a new modification time) is changed again.
  fs::last_write_time(query, fs::last_write_time(query) + std::chrono::seconds(5));
  load(QueryChange::kJpeg);
  EXPECT_NE(test::ReadFileBytes(variant), kept);
  // So is a variant without its stamp (a cache written before stamps, or half written).
  test::WriteFileBytes(variant, kept);
  fs::remove(variant + ".stamp");
  load(QueryChange::kJpeg);
  EXPECT_NE(test::ReadFileBytes(variant), kept);
  EXPECT_TRUE(fs::exists(variant + ".stamp"));

  context_.cache_dir.clear();
  const auto without_cache = LoadSet(set_, extractor_, context_);
  EXPECT_EQ(without_cache.status().code(), StatusCode::kInvalidArgument);
}

// A whole set: both maps trained, every query answered by all four methods and the
// session, the negatives counted; the figures are those of the answers.
TEST_F(SuiteRunTest, RunSetAnswersEveryQueryWithEveryMethod) {
  ASSERT_TRUE(WriteTour(test::SmallTour(3, 9), dir_.File("elsewhere"), kTrainingPass).ok());
  set_.negative_dirs = {dir_.File("elsewhere")};
  SuiteSettings settings;
  settings.train.extractor = extractor_;
  ASSERT_TRUE(
      LoadTrainOptions(SCENELOC_CONFIGS_DIR "/paper-train.yaml", &settings.paper_train).ok());
  ASSERT_TRUE(
      LoadMatchOptions(SCENELOC_CONFIGS_DIR "/paper-match.yaml", &settings.paper_match).ok());
  const auto result = RunSet(set_, settings, context_);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->locations, kLocations);
  EXPECT_GT(result->landmarks, 0);
  ASSERT_EQ(result->outcomes.size(), static_cast<size_t>(kLocations));
  EXPECT_EQ(result->paper_outcomes.size(), static_cast<size_t>(kLocations));
  EXPECT_EQ(result->session_outcomes.size(), static_cast<size_t>(kLocations));
  for (int q = 0; q < kLocations; ++q) {
    EXPECT_EQ(result->outcomes[q].truth, q);
    EXPECT_EQ(result->outcomes[q].name, TourImageName(q));
    EXPECT_GE(result->outcomes[q].baseline.predicted, 0);
  }
  EXPECT_EQ(result->summary.queries, static_cast<size_t>(kLocations));
  EXPECT_TRUE(result->summary.has_baseline);
  const MethodSummary ours = SummariseMethod(
      result->outcomes, Method::kOurs, {settings.train.tolerance, settings.match.min_confidence});
  for (int k = 0; k <= kMaxTolerance; ++k) {
    EXPECT_EQ(result->summary.ours.match_rate[k], ours.match_rate[k]);
    if (k > 0) {
      EXPECT_GE(ours.match_rate[k], ours.match_rate[k - 1]);
    }
  }
  EXPECT_GT(ours.match_rate[1], 0.5);
  EXPECT_EQ(result->session.confidence.threshold, settings.match.sequence.min_confidence);
  EXPECT_EQ(result->negatives, 3u);
  EXPECT_LE(result->negatives_accepted, result->negatives);
}

// The set's queries against its tour padded to the map size: first the set's frames from
// elsewhere, then the generated distractors; the paper and the baselines do not run; the
// off-route frames are the negatives. The padded map is kept in the cache and read back
// (same answers, no training) while its images are the same.
TEST_F(SuiteRunTest, DistractorsPadTheMapAndItIsKept) {
  ASSERT_TRUE(WriteTour(test::SmallTour(3, 9), dir_.File("elsewhere"), kTrainingPass).ok());
  ASSERT_TRUE(WriteTour(test::SmallTour(6, 21), dir_.File("distractors"), kTrainingPass).ok());
  ASSERT_TRUE(WriteTour(test::SmallTour(2, 33), dir_.File("offroute"), kTestPass).ok());
  set_.negative_dirs = {dir_.File("elsewhere")};
  SuiteSettings settings;
  settings.train.extractor = extractor_;
  DistractorOptions distractors;
  distractors.generated = *ListImageFiles(dir_.File("distractors"));
  distractors.locations = kLocations + 3 + 4;
  distractors.offroute_dir = dir_.File("offroute");

  const auto result = RunSetWithDistractors(set_, settings, context_, distractors);
  ASSERT_TRUE(result.ok()) << result.status().ToString();
  EXPECT_EQ(result->locations, distractors.locations);
  EXPECT_FALSE(result->comparisons);
  EXPECT_GT(result->train_seconds, 0);
  ASSERT_EQ(result->outcomes.size(), static_cast<size_t>(kLocations));
  EXPECT_EQ(result->session_outcomes.size(), static_cast<size_t>(kLocations));
  EXPECT_TRUE(result->paper_outcomes.empty());
  EXPECT_FALSE(result->summary.has_baseline);
  EXPECT_GT(result->summary.ours.match_rate[1], 0.5);
  EXPECT_EQ(result->negatives, 2u);

  const auto again = RunSetWithDistractors(set_, settings, context_, distractors);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  EXPECT_EQ(again->train_seconds, 0);
  for (int q = 0; q < kLocations; ++q) {
    EXPECT_EQ(again->outcomes[q].ours.predicted, result->outcomes[q].ours.predicted);
  }

  // Another size is another map; more than the distractors can pad, or less than the
  // tour, is an error that says so.
  distractors.locations = kLocations + 3 + 6;
  const auto bigger = RunSetWithDistractors(set_, settings, context_, distractors);
  ASSERT_TRUE(bigger.ok()) << bigger.status().ToString();
  EXPECT_EQ(bigger->locations, distractors.locations);
  EXPECT_GT(bigger->train_seconds, 0);
  distractors.locations = kLocations + 3 + 7;
  const auto short_of = RunSetWithDistractors(set_, settings, context_, distractors);
  EXPECT_EQ(short_of.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(short_of.status().message().find("holds 6"), std::string::npos)
      << short_of.status().message();
  distractors.locations = kLocations - 1;
  EXPECT_EQ(RunSetWithDistractors(set_, settings, context_, distractors).status().code(),
            StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace sceneloc
