// Features of generated tours (common/synthetic/tour_generator.h) for tests that need a
// real map or real feature sets: real JPEG bytes, decoded and extracted as training and
// the server do.
#pragma once

#include <cstdint>
#include <vector>

#include "common/features/extractor.h"
#include "common/features/feature_set.h"
#include "common/synthetic/tour_generator.h"

namespace sceneloc::test {

// A tour of `locations` small images (320x180), its other options the defaults.
TourOptions SmallTour(int locations, uint32_t seed = 1);

// Every image of pass `pass` of `tour` extracted with `options`: in its own tour frame
// when `map_frame` is null, else as a query for a map of that frame (QueryTarget).
// gtest-nonfatal failures (and an empty result) when rendering or extraction fails.
std::vector<FeatureSet> ExtractTourPass(const TourOptions& tour, int pass,
                                        const ExtractorOptions& options,
                                        const ExtractionTarget* map_frame = nullptr);

// The frame a map trained from `tour_features` works in: the first image's.
ExtractionTarget MapFrameOf(const std::vector<FeatureSet>& tour_features);

// Expects (gtest EXPECT_*) `a` and `b` equal, bit for bit.
void ExpectFeatureSetsEqual(const FeatureSet& a, const FeatureSet& b);

}  // namespace sceneloc::test
