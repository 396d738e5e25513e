// The voting baselines (common/matching/baseline.h): votes by nearest neighbour and ratio
// test, the vote share, ties, and the re-ranking by RANSAC inliers, on descriptors and
// views made in code.
#include "common/matching/baseline.h"

#include <gtest/gtest.h>

#include <random>

#include "tests/support/two_view.h"

namespace sceneloc {
namespace {

constexpr int kPerImage = 60;

// Non-negative unit rows, like SIFT descriptors.
DescriptorMatrix RandomDescriptors(int n, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0, 1);
  DescriptorMatrix m(n, kDescriptorSize);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < kDescriptorSize; ++j) m(i, j) = u(rng);
    m.row(i).normalize();
  }
  return m;
}

// A tour of `images` images of kPerImage features each, every descriptor distinct; image
// l's keypoints are the first view of TwoViewPoints(kPerImage, l).
std::vector<FeatureSet> MakeTour(int images, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<FeatureSet> tour(images);
  for (int l = 0; l < images; ++l) {
    FeatureSet& f = tour[l];
    f.image_width = 480;
    f.image_height = 270;
    f.local = RandomDescriptors(kPerImage, rng);
    f.context = f.local;
    for (const test::PointPair& p : test::TwoViewPoints(kPerImage, l)) {
      f.keypoints.push_back({p.x0, p.y0, 2, 0, 1, 0});
    }
  }
  return tour;
}

// A query holding `count` features of tour image `l` (its descriptors, seen from the
// second view of the same scene), appended to `query`.
void AddFeaturesOf(const std::vector<FeatureSet>& tour, int l, int count, FeatureSet* query) {
  const std::vector<test::PointPair> pairs = test::TwoViewPoints(kPerImage, l);
  const int start = query->size();
  query->local.conservativeResize(start + count, Eigen::NoChange);
  for (int i = 0; i < count; ++i) {
    query->local.row(start + i) = tour[l].local.row(i);
    query->keypoints.push_back({pairs[i].x1, pairs[i].y1, 2, 0, 1, 0});
  }
  query->context = query->local;
  query->image_width = 480;
  query->image_height = 270;
}

std::unique_ptr<VotingBaseline> Build(const std::vector<FeatureSet>& tour,
                                      const BaselineOptions& options = {}) {
  auto built = VotingBaseline::Build(tour, options);
  EXPECT_TRUE(built.ok()) << built.status().ToString();
  return built.ok() ? std::move(built).value() : nullptr;
}

// Every feature of one tour image votes for it: the best is that image, with all the
// share; re-ranking agrees and finds the two views' geometry.
TEST(BaselineTest, AQueryOfOneImageVotesForIt) {
  const std::vector<FeatureSet> tour = MakeTour(5, 1);
  FeatureSet query;
  AddFeaturesOf(tour, 3, kPerImage, &query);
  const BaselineResult r = Build(tour)->Localise(query);
  ASSERT_EQ(r.votes.size(), 5u);
  EXPECT_EQ(r.votes[3], kPerImage);
  EXPECT_EQ(r.best, 3);
  EXPECT_FLOAT_EQ(r.confidence, 1.0f);
  EXPECT_EQ(r.reranked_best, 3);
  EXPECT_GE(r.reranked_inliers, kPerImage * 9 / 10);
  EXPECT_FLOAT_EQ(r.reranked_confidence, 1.0f);
}

// Votes split between two images: the larger wins with share v1 / (v1 + v2).
TEST(BaselineTest, ConfidenceIsTheVoteShare) {
  const std::vector<FeatureSet> tour = MakeTour(5, 2);
  FeatureSet query;
  AddFeaturesOf(tour, 1, 40, &query);
  AddFeaturesOf(tour, 4, 20, &query);
  BaselineOptions options;
  options.rerank_top = 0;
  const BaselineResult r = Build(tour, options)->Localise(query);
  EXPECT_EQ(r.votes[1], 40);
  EXPECT_EQ(r.votes[4], 20);
  EXPECT_EQ(r.best, 1);
  EXPECT_FLOAT_EQ(r.confidence, 40.0f / 60.0f);
  EXPECT_EQ(r.reranked_best, -1);  // re-ranking off
}

// Equal votes go to the lower image index.
TEST(BaselineTest, TiesGoToTheLowerIndex) {
  const std::vector<FeatureSet> tour = MakeTour(4, 3);
  FeatureSet query;
  AddFeaturesOf(tour, 2, 10, &query);
  AddFeaturesOf(tour, 0, 10, &query);
  const BaselineResult r = Build(tour)->Localise(query);
  EXPECT_EQ(r.best, 0);
  EXPECT_FLOAT_EQ(r.confidence, 0.5f);
}

// A feature whose two nearest tour features are equally near fails the ratio test and
// votes for nobody: a tour of two identical images gets no vote at all.
TEST(BaselineTest, AmbiguousFeaturesDoNotVote) {
  std::vector<FeatureSet> tour = MakeTour(1, 4);
  tour.push_back(tour[0]);
  FeatureSet query;
  AddFeaturesOf(tour, 0, 30, &query);
  const BaselineResult r = Build(tour)->Localise(query);
  EXPECT_EQ(r.votes, (std::vector<int>{0, 0}));
  EXPECT_EQ(r.best, -1);
  EXPECT_EQ(r.confidence, 0.0f);
}

// An empty query gets no votes and no answer; a tour without features cannot be built.
TEST(BaselineTest, EmptyInputs) {
  const std::vector<FeatureSet> tour = MakeTour(3, 5);
  FeatureSet empty;
  const BaselineResult r = Build(tour)->Localise(empty);
  EXPECT_EQ(r.votes, (std::vector<int>{0, 0, 0}));
  EXPECT_EQ(r.best, -1);
  const auto none = VotingBaseline::Build({FeatureSet(), FeatureSet()}, BaselineOptions());
  EXPECT_EQ(none.status().code(), StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace sceneloc
