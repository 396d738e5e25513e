// The place index (common/map/place_index.h) built at training, and the coarse stage that
// reads it (common/matching/place_search.h, landmark_scope.h), on a generated tour: real
// JPEG bytes, a real trained map, the test pass as queries.
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <numeric>

#include "common/map/compact.h"
#include "common/map/map_io.h"
#include "common/map/map_layout.h"
#include "common/map/payload_archive.h"
#include "common/matching/descriptor_similarity.h"
#include "common/matching/holistic_similarity.h"
#include "common/matching/landmark_scope.h"
#include "common/matching/localiser.h"
#include "common/matching/place_search.h"
#include "common/training/place_index_builder.h"
#include "common/training/trainer.h"
#include "tests/support/test_map.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 48;

class PlaceIndexTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const TourOptions tour = test::SmallTour(kLocations, 4);
    TrainOptions options;
    options.place_index_min_locations = 20;
    const std::vector<FeatureSet> features =
        test::ExtractTourPass(tour, kTrainingPass, options.extractor);
    std::vector<std::string> names;
    for (int i = 0; i < kLocations; ++i) names.push_back(TourImageName(i));
    auto trained = TrainFromFeatures(features, names, options, 2, nullptr);
    ASSERT_TRUE(trained.ok()) << trained.status().ToString();
    map_ = new Map(std::move(trained->map));
    const ExtractionTarget frame = test::MapFrameOf(features);
    queries_ = new std::vector<FeatureSet>(
        test::ExtractTourPass(tour, kTestPass, options.extractor, &frame));
  }
  static void TearDownTestSuite() {
    delete map_;
    delete queries_;
    map_ = nullptr;
    queries_ = nullptr;
  }
  static Map* map_;
  static std::vector<FeatureSet>* queries_;
};
Map* PlaceIndexTest::map_ = nullptr;
std::vector<FeatureSet>* PlaceIndexTest::queries_ = nullptr;

// A map of at least place_index_min_locations gets a valid index: a vocabulary sized to its
// landmarks, a word for each, every location's holistic cells coded; it survives the map
// file, and the inverted file made from it on load holds every landmark of every G_l.
TEST_F(PlaceIndexTest, TrainingBuildsAValidIndexThatTheMapFileKeeps) {
  const Map& map = *map_;
  ASSERT_TRUE(map.has_place_index());
  EXPECT_TRUE(map.Validate().ok());
  const PlaceIndex& index = map.place_index;
  const int side = VocabularySide(static_cast<size_t>(map.num_landmarks()));
  EXPECT_EQ(index.vocabulary.coarse, side);
  EXPECT_EQ(index.vocabulary.fine, side);
  EXPECT_EQ(index.landmark_word.size(), static_cast<size_t>(map.num_landmarks()));
  EXPECT_EQ(index.holistic.bins, map.holistic_grid.bins);
  EXPECT_EQ(index.holistic.codebook.size(),
            static_cast<size_t>(kHolisticCodes * map.holistic_grid.bins));
  EXPECT_EQ(index.holistic.codes.size(),
            static_cast<size_t>(map.num_images() * map.holistic_grid.cells()));
  auto parsed = ParseMap(SerializeMap(map), "resaved");
  ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
  test::ExpectMapsEqual(map, *parsed);
  EXPECT_EQ(parsed->inverted_file.location, map.inverted_file.location);
  EXPECT_EQ(parsed->inverted_file.signature, map.inverted_file.signature);
  // Each location appears once for every landmark of its G_l, under that landmark's word.
  const InvertedFile& file = map.inverted_file;
  std::vector<std::vector<uint32_t>> posted(static_cast<size_t>(map.num_images()));
  for (size_t w = 0; w + 1 < file.offsets.size(); ++w) {
    for (uint32_t k = file.offsets[w]; k < file.offsets[w + 1]; ++k) {
      posted[file.location[k]].push_back(static_cast<uint32_t>(w));
    }
  }
  for (int l = 0; l < map.num_images(); ++l) {
    std::vector<uint32_t> words;
    for (uint32_t k = map.image_offsets[l]; k < map.image_offsets[l + 1]; ++k) {
      words.push_back(index.landmark_word[map.image_landmarks[k]]);
    }
    std::sort(words.begin(), words.end());
    EXPECT_EQ(posted[static_cast<size_t>(l)], words) << l;
  }
}

// A map of format version 7 stored principal axes of the holistic descriptors instead of
// their codes: its payload is read past them, and the loaded map is coded as training codes
// it, answering as today's map does.
TEST_F(PlaceIndexTest, AVersionSevenMapIsCodedWhenLoaded) {
  const Map& map = *map_;
  std::string bytes;
  map_io_internal::PayloadWriter writer(&bytes);
  map_io_internal::V1Fields v1;
  map_io_internal::TransferMap(writer, map, 7, v1);
  EXPECT_LT(bytes.size(), SerializeMap(map).size());  // no codes, an empty projection
  map_io_internal::MemorySource source(bytes.data());
  map_io_internal::PayloadReader reader(&source, bytes.size());
  Map read;
  map_io_internal::TransferMap(reader, read, 7, v1);
  ASSERT_TRUE(reader.status().ok()) << reader.status().ToString();
  EXPECT_EQ(reader.remaining(), 0u);
  EXPECT_TRUE(read.place_index.holistic.empty());
  ASSERT_TRUE(read.Validate().ok());
  read.Finalize();
  EXPECT_TRUE(read.experiences.empty());  // version 7 has no walks: one, the tour
  read.experiences = map.experiences;
  test::ExpectMapsEqual(map, read);
  const FeatureSet& q = queries_->front();
  EXPECT_EQ(ApproximateHolisticDistances(q, read), ApproximateHolisticDistances(q, map));
}

// The signatures' axes are orthonormal and the same on every call (and machine: integer
// draws, IEEE arithmetic).
TEST(SignatureProjectionTest, OrthonormalAndFixed) {
  const SignatureProjection p = MakeSignatureProjection();
  const Eigen::MatrixXf gram = p * p.transpose();
  EXPECT_TRUE(gram.isApprox(Eigen::MatrixXf::Identity(kSignatureBits, kSignatureBits), 1e-5f));
  EXPECT_EQ(MakeSignatureProjection(), p);
}

// A landmark's mean descriptor, asked as a query descriptor, gets the signature its
// occurrences carry; and each bit splits its word's landmarks at their median.
TEST_F(PlaceIndexTest, SignaturesAreTheLandmarksOwnAndSplitEachWordInHalves) {
  const Map& map = *map_;
  const InvertedFile& file = map.inverted_file;
  const auto n = static_cast<Eigen::Index>(map.num_landmarks());
  DescriptorMatrix means(n, kDescriptorSize);
  for (Eigen::Index g = 0; g < n; ++g) map.LocalMean(static_cast<int>(g), means.row(g).data());
  const std::vector<uint64_t> own = Signatures(file, means, map.place_index.landmark_word);
  std::vector<uint64_t> stored(static_cast<size_t>(n));
  std::vector<bool> seen(static_cast<size_t>(n), false);
  for (int l = 0; l < map.num_images(); ++l) {
    for (uint32_t k = map.image_offsets[l]; k < map.image_offsets[l + 1]; ++k) {
      seen[map.image_landmarks[k]] = true;
    }
  }
  // The occurrences in file order are the locations' landmarks in location order, by word.
  std::vector<uint32_t> fill(file.offsets.begin(), file.offsets.end() - 1);
  for (int l = 0; l < map.num_images(); ++l) {
    for (uint32_t k = map.image_offsets[l]; k < map.image_offsets[l + 1]; ++k) {
      const uint32_t g = map.image_landmarks[k];
      stored[g] = file.signature[fill[map.place_index.landmark_word[g]]++];
    }
  }
  std::vector<std::vector<uint64_t>> by_word(file.offsets.size() - 1);
  for (Eigen::Index g = 0; g < n; ++g) {
    if (seen[static_cast<size_t>(g)]) {
      EXPECT_EQ(own[static_cast<size_t>(g)], stored[static_cast<size_t>(g)]) << g;
    }
    by_word[map.place_index.landmark_word[static_cast<size_t>(g)]].push_back(
        own[static_cast<size_t>(g)]);
  }
  int words_checked = 0;
  for (const std::vector<uint64_t>& signatures : by_word) {
    if (signatures.size() < 8) continue;
    ++words_checked;
    for (int bit = 0; bit < kSignatureBits; ++bit) {
      size_t set = 0;
      for (uint64_t s : signatures) set += (s >> bit) & 1u;
      // Strictly above the median element: about half, fewer when values tie.
      EXPECT_LE(set, signatures.size() / 2);
      EXPECT_GE(set + 2, (signatures.size() - 1) / 2);
    }
  }
  EXPECT_GT(words_checked, 0);
}

// A tighter Hamming limit only removes word matches: every location's score falls or stays.
TEST_F(PlaceIndexTest, ATighterHammingLimitOnlyRemovesMatches) {
  int lower = 0;
  for (const FeatureSet& q : *queries_) {
    const std::vector<float> loose = WordScores(q, *map_, 64);
    const std::vector<float> tight = WordScores(q, *map_, 20);
    ASSERT_EQ(loose.size(), tight.size());
    for (size_t l = 0; l < loose.size(); ++l) {
      EXPECT_LE(tight[l], loose[l] * (1 + 1e-6f)) << l;
      lower += tight[l] < loose[l];
    }
  }
  EXPECT_GT(lower, 0) << "no word match was beyond 20 bits";
}

// Smaller maps, or a setting of 0, get none: they are searched whole.
TEST(PlaceIndexBuilderTest, NoIndexBelowTheSize) {
  for (int min_locations : {0, 7}) {
    Map map = test::MakeRandomMap(6, 50, 3);
    map.options.place_index_min_locations = min_locations;
    BuildPlaceIndex(&map, nullptr);
    EXPECT_FALSE(map.has_place_index()) << min_locations;
  }
  Map map = test::MakeRandomMap(6, 50, 3);
  map.options.place_index_min_locations = 6;
  BuildPlaceIndex(&map, nullptr);
  EXPECT_TRUE(map.has_place_index());
  EXPECT_TRUE(map.Validate().ok());
}

// The approximate holistic distance ranks like the exact one: each query's exactly nearest
// location is among its approximately nearest two, and the values are on the exact one's
// scale. The shortlist is the nearest by it, ascending.
TEST_F(PlaceIndexTest, ApproximateHolisticDistanceFindsTheNearest) {
  const Map& map = *map_;
  int within = 0;
  for (const FeatureSet& q : *queries_) {
    const std::vector<float> exact = HolisticDistances(q, map, 2, nullptr);
    const std::vector<float> approximate = ApproximateHolisticDistances(q, map);
    ASSERT_EQ(approximate.size(), exact.size());
    for (size_t l = 0; l < exact.size(); ++l) {
      EXPECT_NEAR(approximate[l], exact[l], 0.25f * exact[l]) << "location " << l;
    }
    const int nearest =
        static_cast<int>(std::min_element(exact.begin(), exact.end()) - exact.begin());
    const int rank =
        static_cast<int>(std::count_if(approximate.begin(), approximate.end(), [&](float d) {
          return d < approximate[static_cast<size_t>(nearest)];
        }));
    within += rank < 2;
    const std::vector<int> shortlist = HolisticShortlist(approximate, 3);
    EXPECT_EQ(shortlist.size(), 3u);
    EXPECT_TRUE(std::is_sorted(shortlist.begin(), shortlist.end()));
    if (rank < 3) {
      EXPECT_NE(std::find(shortlist.begin(), shortlist.end(), nearest), shortlist.end());
    }
  }
  EXPECT_GE(within, kLocations * 9 / 10);
}

// Every lateral shift the comparison allows is read: a location that holds the query's own
// descriptor moved by s cells (its cells (r, c - s) are the query's (r, c)) is the nearest by
// the approximation, at about its exact distance, for each s in [-max_shift, max_shift].
TEST_F(PlaceIndexTest, ApproximateDistanceReadsEveryLateralShift) {
  const FeatureSet& q = queries_->front();
  const HolisticGrid& grid = map_->holistic_grid;
  const int max_shift = map_->options.extractor.holistic.max_shift;
  ASSERT_GT(max_shift, 0);
  constexpr int kPlanted = 30;
  for (int shift = -max_shift; shift <= max_shift; ++shift) {
    Map map = *map_;
    uint8_t* planted = map.holistic.data() + static_cast<size_t>(kPlanted) * grid.size();
    for (int r = 0; r < grid.rows; ++r) {
      for (int c = 0; c < grid.cols; ++c) {
        if (c - shift < 0 || c - shift >= grid.cols) continue;
        for (int b = 0; b < grid.bins; ++b) {
          const float v = q.holistic[static_cast<size_t>((r * grid.cols + c) * grid.bins + b)];
          planted[(r * grid.cols + c - shift) * grid.bins + b] = UnitByte(v);
        }
      }
    }
    map.place_index.holistic =
        CodeHolistic(map.holistic, grid, static_cast<size_t>(map.num_images()), nullptr);
    const std::vector<float> approximate = ApproximateHolisticDistances(q, map);
    const std::vector<float> exact = HolisticDistances(q, map, max_shift, nullptr);
    EXPECT_EQ(std::min_element(approximate.begin(), approximate.end()) - approximate.begin(),
              kPlanted)
        << "shift " << shift;
    EXPECT_LT(exact[kPlanted], 1e-4f) << "shift " << shift;
    float others = std::numeric_limits<float>::max();  // the nearest other location, exactly
    for (int l = 0; l < map.num_images(); ++l) {
      if (l != kPlanted) others = std::min(others, exact[static_cast<size_t>(l)]);
    }
    EXPECT_LT(approximate[kPlanted], 0.5f * others) << "shift " << shift;
  }
}

// A scope of every location is the whole map: the coarse stage asked for more candidates
// than there are locations answers exactly as the paper's search of every landmark.
TEST_F(PlaceIndexTest, AScopeOfEveryLocationAnswersAsTheWholeMap) {
  MatchOptions whole;
  whole.use_place_index = false;
  MatchOptions all = whole;
  all.use_place_index = true;
  all.place_word_top = 1000;
  for (size_t q = 0; q < queries_->size(); q += 7) {
    auto a = Localise((*queries_)[q], *map_, whole, nullptr);
    auto b = Localise((*queries_)[q], *map_, all, nullptr);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_EQ(a->ranked.size(), b->ranked.size());
    for (size_t i = 0; i < a->ranked.size(); ++i) {
      EXPECT_EQ(a->ranked[i].index, b->ranked[i].index);
      EXPECT_EQ(a->ranked[i].likelihood, b->ranked[i].likelihood);
    }
    EXPECT_EQ(a->confidence, b->confidence) << "query " << q;
    EXPECT_EQ(a->location_scores, b->location_scores);
    EXPECT_EQ(a->descriptor_matches, b->descriptor_matches);
  }
}

// With a narrow coarse stage (a few locations by words and by holistic distance, one either
// side) the fine stage scores a fraction of the map and still answers as the whole map does.
TEST_F(PlaceIndexTest, ANarrowScopeAnswersAsTheWholeMap) {
  MatchOptions whole;
  whole.use_place_index = false;
  MatchOptions narrow;
  narrow.place_word_top = 3;
  narrow.place_holistic_top = 3;
  narrow.place_expand = 1;
  int same = 0, scored = 0;
  for (const FeatureSet& q : *queries_) {
    const PlaceSearch search = SearchPlaces(q, *map_, narrow);
    scored += static_cast<int>(search.locations.size());
    auto a = Localise(q, *map_, whole, nullptr);
    auto b = Localise(q, *map_, narrow, nullptr);
    ASSERT_TRUE(a.ok() && b.ok());
    same += a->ranked[0].index == b->ranked[0].index;
  }
  EXPECT_LT(scored, kLocations * kLocations / 2) << "the scope was most of the map";
  EXPECT_GE(same, kLocations * 9 / 10);
}

// Distinct picks: the word picks are, in order of their score, the best locations not
// already among the candidates, so every pick brings a stretch of the route not yet scored;
// without them the best place_word_top, however close together.
TEST_F(PlaceIndexTest, DistinctPicksAreDistinctPlaces) {
  MatchOptions options;
  options.place_word_top = 4;
  options.place_holistic_top = 0;
  options.place_expand = 2;
  int wider = 0;
  for (const FeatureSet& q : *queries_) {
    const std::vector<float> score = WordScores(q, *map_, options.place_hamming_max);
    std::vector<int> order(score.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return score[a] > score[b]; });
    // The rule, written out: walk the locations best first, pick one unless it is chosen.
    std::vector<bool> chosen(score.size(), false);
    std::vector<bool> plain(score.size(), false);
    for (int i = 0, picked = 0; i < kLocations && picked < options.place_word_top; ++i) {
      const int l = order[static_cast<size_t>(i)];
      for (int m = std::max(0, l - 2); m <= std::min(kLocations - 1, l + 2); ++m) {
        if (i < options.place_word_top) plain[static_cast<size_t>(m)] = true;
      }
      if (chosen[static_cast<size_t>(l)]) continue;
      for (int m = std::max(0, l - 2); m <= std::min(kLocations - 1, l + 2); ++m) {
        chosen[static_cast<size_t>(m)] = true;
      }
      ++picked;
    }
    std::vector<int> expected, expected_plain;
    for (int l = 0; l < kLocations; ++l) {
      if (chosen[static_cast<size_t>(l)]) expected.push_back(l);
      if (plain[static_cast<size_t>(l)]) expected_plain.push_back(l);
    }
    options.place_distinct = true;
    EXPECT_EQ(SearchPlaces(q, *map_, options).locations, expected);
    options.place_distinct = false;
    EXPECT_EQ(SearchPlaces(q, *map_, options).locations, expected_plain);
    wider += expected.size() > expected_plain.size();
  }
  EXPECT_GT(wider, 0) << "no query's best word locations were close together";
}

// The coarse stage spread over a pool finds what it finds alone.
TEST_F(PlaceIndexTest, APoolChangesNothing) {
  ThreadPool pool(3);
  MatchOptions options;
  options.place_word_top = 5;
  options.place_holistic_top = 5;
  options.place_expand = 1;
  for (const FeatureSet& q : *queries_) {
    EXPECT_EQ(WordScores(q, *map_, options.place_hamming_max, &pool),
              WordScores(q, *map_, options.place_hamming_max));
    EXPECT_EQ(ApproximateHolisticDistances(q, *map_, &pool),
              ApproximateHolisticDistances(q, *map_));
    const PlaceSearch alone = SearchPlaces(q, *map_, options);
    const PlaceSearch spread = SearchPlaces(q, *map_, options, &pool);
    EXPECT_EQ(spread.locations, alone.locations);
    EXPECT_EQ(spread.holistic, alone.holistic);
  }
}

// A scope's matches are the whole map's matches of its landmarks, numbered by position.
TEST_F(PlaceIndexTest, ScopeMatchesAreTheWholeMapsOfItsLandmarks) {
  const Map& map = *map_;
  const FeatureSet& q = (*queries_)[10];
  const LandmarkScope scope = LandmarkScope::Of(map, {8, 9, 10, 11, 30});
  ASSERT_GT(scope.size(), 0u);
  const auto whole = ComputeDescriptorMatches(q, map, 0.3f, nullptr, 32);
  const auto part = ComputeDescriptorMatches(q, map, scope, 0.3f, nullptr, 32);
  std::vector<DescriptorMatch> expected;
  for (const DescriptorMatch& m : whole) {
    const int32_t p = scope.Position(m.landmark);
    if (p >= 0) expected.push_back({m.feature, static_cast<uint32_t>(p), m.similarity});
  }
  ASSERT_EQ(part.size(), expected.size());
  for (size_t i = 0; i < part.size(); ++i) {
    EXPECT_EQ(part[i].feature, expected[i].feature);
    EXPECT_EQ(part[i].landmark, expected[i].landmark);
    EXPECT_EQ(part[i].similarity, expected[i].similarity);
  }
}

// Positions map both ways; a scope's positions are cleared when it ends, so the next scope
// (which may reuse the same array) sees only its own landmarks.
TEST_F(PlaceIndexTest, ScopePositionsAreItsOwn) {
  const Map& map = *map_;
  std::vector<uint32_t> first_landmarks;
  {
    const LandmarkScope first = LandmarkScope::Of(map, {0, 1});
    for (size_t i = 0; i < first.size(); ++i) {
      EXPECT_EQ(first.Position(first.landmark(i)), static_cast<int32_t>(i));
      first_landmarks.push_back(first.landmark(i));
    }
  }
  const LandmarkScope second = LandmarkScope::Of(map, {40});
  for (uint32_t g : first_landmarks) {
    bool in_second = false;
    for (uint32_t k = map.image_offsets[40]; k < map.image_offsets[41]; ++k) {
      in_second |= map.image_landmarks[k] == g;
    }
    if (!in_second) {
      EXPECT_EQ(second.Position(g), -1) << g;
    }
  }
  const LandmarkScope whole = LandmarkScope::Whole(map);
  EXPECT_EQ(whole.size(), static_cast<size_t>(map.num_landmarks()));
  EXPECT_EQ(whole.Position(5), 5);
}

}  // namespace
}  // namespace sceneloc
