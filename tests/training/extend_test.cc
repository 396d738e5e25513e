// Maps that grow by walks (common/training/extend.h), on generated streets (real JPEG bytes,
// real trained maps): a darker walk of the route becomes an experience aligned to its places
// by the localiser alone, a walk of another street is refused as one and added as new ground
// on request, and the extended map answers with places and survives its file.
#include "common/training/extend.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "common/map/map_io.h"
#include "common/training/trainer.h"
#include "tests/support/scratch_dir.h"
#include "tests/support/tour_features.h"

namespace sceneloc {
namespace {

constexpr int kLocations = 40;

std::vector<std::string> Names(int count) {
  std::vector<std::string> names;
  for (int i = 0; i < count; ++i) names.push_back(TourImageName(i));
  return names;
}

// The street the map is trained on: the default pass, 40 locations.
TourOptions Street(uint32_t seed = 1) { return test::SmallTour(kLocations, seed); }

// The same street walked at dusk, displaced sideways and `forward` of a step along: dark and
// noisy enough that the day's map finds about half of its frames.
TourOptions Dusk(double forward) {
  TourOptions t = Street();
  t.brightness_gain = 0.12;
  t.brightness_offset = 0;
  t.noise_stddev = 14;
  t.lateral_shift = -0.1;
  t.forward_offset = forward;
  return t;
}

class ExtendTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    TrainOptions options;
    const std::vector<FeatureSet> tour =
        test::ExtractTourPass(Street(), kTrainingPass, options.extractor);
    auto trained = TrainFromFeatures(tour, Names(kLocations), options, 2, nullptr);
    ASSERT_TRUE(trained.ok()) << trained.status().ToString();
    map_ = new Map(std::move(trained->map));
    frame_ = test::MapFrameOf(tour);
  }
  static void TearDownTestSuite() { delete map_; }

  // Pass `pass` of `tour` extracted as the map's queries are.
  static std::vector<FeatureSet> Walk(const TourOptions& tour, int pass = kTestPass) {
    return test::ExtractTourPass(tour, pass, map_->options.extractor, &frame_);
  }
  static StatusOr<ExtendResult> Extend(const std::vector<FeatureSet>& walk, bool new_ground) {
    ExtendOptions options;
    options.name = new_ground ? "next street" : "dusk";
    options.new_ground = new_ground;
    return ExtendMap(*map_, TourInMemory(walk), Names(static_cast<int>(walk.size())), options, 2,
                     nullptr);
  }
  // The share of `queries` (query i shows place first + i) answered within +-2.
  static double WithinTwo(const Map& map, const std::vector<FeatureSet>& queries, int first = 0) {
    int right = 0;
    for (size_t i = 0; i < queries.size(); ++i) {
      auto r = Localise(queries[i], map, MatchOptions(), nullptr);
      EXPECT_TRUE(r.ok()) << r.status().ToString();
      if (!r.ok() || r->ranked.empty()) continue;
      EXPECT_LT(r->ranked[0].index, map.num_places());
      EXPECT_EQ(r->ranked[0].image_name, map.PlaceName(r->ranked[0].index));
      right += std::abs(r->ranked[0].index - (first + static_cast<int>(i))) <= 2;
    }
    return static_cast<double>(right) / static_cast<double>(queries.size());
  }

  static Map* map_;
  static ExtractionTarget frame_;
};

Map* ExtendTest::map_ = nullptr;
ExtractionTarget ExtendTest::frame_;

// A dusk walk of the route is aligned to the map's places by localising it as a session,
// never by its file names: nearly every frame placed, and placed within +-2 of where it was
// taken. The extended map keeps its places, shows them in more images, records the walk, and
// answers another dusk walk better than the map of the day alone.
TEST_F(ExtendTest, ADuskWalkBecomesAnExperienceOfTheRoute) {
  const std::vector<FeatureSet> walk = Walk(Dusk(0.0));
  ASSERT_EQ(walk.size(), static_cast<size_t>(kLocations));
  auto extended = Extend(walk, false);
  ASSERT_TRUE(extended.ok()) << extended.status().ToString();
  const ExtendSummary& s = extended->summary;
  const Map& map = extended->map;
  EXPECT_GE(s.aligned + s.bridged, static_cast<size_t>(kLocations * 9 / 10));
  int placed = 0, right = 0;
  for (size_t i = 0; i < s.frames.size(); ++i) {
    if (s.frames[i].place < 0) continue;
    ++placed;
    right += std::abs(s.frames[i].place - static_cast<int>(i)) <= 2;
  }
  EXPECT_GE(right, placed * 95 / 100) << right << " of " << placed;
  EXPECT_GT(s.added, 0u);
  EXPECT_EQ(s.added + s.recognised + (s.frames.size() - s.aligned - s.bridged), s.frames.size());
  EXPECT_EQ(map.num_places(), kLocations);
  EXPECT_EQ(map.num_images(), kLocations + static_cast<int>(s.added));
  ASSERT_EQ(map.experiences.size(), 2u);
  EXPECT_EQ(map.experiences[1].kind, ExperienceKind::kRoute);
  EXPECT_EQ(map.experiences[1].name, "dusk");
  EXPECT_EQ(map.experiences[1].walk_frames, static_cast<uint32_t>(kLocations));
  EXPECT_TRUE(map.experiences[1].calibration.valid);
  EXPECT_EQ(map.num_landmarks(), map_->num_landmarks() + static_cast<int>(s.landmarks_added));
  ASSERT_TRUE(map.Validate().ok()) << map.Validate().ToString();
  // The same places: robots' sessions continue across the reload (server/session_store.h).
  EXPECT_EQ(map.PlacesKey(), map_->PlacesKey());

  const std::vector<FeatureSet> later = Walk(Dusk(0.45));
  const double before = WithinTwo(*map_, later), after = WithinTwo(map, later);
  std::printf("dusk walk +-2: the day's map %.3f, with a dusk walk %.3f\n", before, after);
  EXPECT_GE(after, before + 0.1) << "day map " << before << ", with the dusk walk " << after;
  EXPECT_GE(after, 0.8);
  // The day still answers as it did.
  const std::vector<FeatureSet> day = Walk(Street());
  EXPECT_GE(WithinTwo(map, day), WithinTwo(*map_, day) - 0.05);

  // Its file holds the places and the walks.
  test::ScratchDir dir("extend_test");
  const std::string path = (dir.path() / "extended.scnl").string();
  ASSERT_TRUE(SaveMap(map, path).ok());
  auto loaded = LoadMap(path);
  ASSERT_TRUE(loaded.ok()) << loaded.status().ToString();
  EXPECT_EQ(loaded->image_place, map.image_place);
  EXPECT_EQ(loaded->num_places(), kLocations);
  ASSERT_EQ(loaded->experiences.size(), 2u);
  EXPECT_EQ(loaded->experiences[1].first_image, static_cast<uint32_t>(kLocations));
}

// A walk of another street matches nothing of the map: refused as an experience of the route,
// saying so and that it can be added as new ground; added as new ground it becomes new
// places after the map's, which answer its frames, while the route's still answer the route.
TEST_F(ExtendTest, AnotherStreetIsNewGround) {
  const std::vector<FeatureSet> walk = Walk(Street(7), kTrainingPass);
  const auto refused = Extend(walk, false);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.status().message().find("new ground"), std::string::npos)
      << refused.status().message();

  auto extended = Extend(walk, true);
  ASSERT_TRUE(extended.ok()) << extended.status().ToString();
  const Map& map = extended->map;
  EXPECT_EQ(map.num_places(), 2 * kLocations);
  EXPECT_EQ(extended->summary.new_places, static_cast<size_t>(kLocations));
  ASSERT_EQ(map.experiences.size(), 2u);
  EXPECT_EQ(map.experiences[1].kind, ExperienceKind::kNewGround);
  EXPECT_NE(map.PlacesKey(), map_->PlacesKey());  // other places: sessions start again
  TourOptions street7 = Street(7);
  EXPECT_GE(WithinTwo(map, Walk(street7), kLocations), 0.8);
  EXPECT_GE(WithinTwo(map, Walk(Street())), WithinTwo(*map_, Walk(Street())) - 0.05);
}

// Frames extracted in another working frame, or too few, are refused before any work.
TEST_F(ExtendTest, RefusesWalksItCannotRead) {
  std::vector<FeatureSet> walk = Walk(Dusk(0.0));
  walk.resize(1);
  EXPECT_EQ(Extend(walk, false).status().code(), StatusCode::kFailedPrecondition);
  std::vector<FeatureSet> other =
      test::ExtractTourPass(Dusk(0.0), kTestPass, map_->options.extractor);
  for (FeatureSet& f : other) f.image_width += 1;
  const auto refused = Extend(other, false);
  EXPECT_EQ(refused.status().code(), StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.status().message().find("working frame"), std::string::npos)
      << refused.status().message();
}

}  // namespace
}  // namespace sceneloc
