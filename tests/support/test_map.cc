#include "tests/support/test_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

namespace sceneloc::test {
namespace {

constexpr int kWidth = 480;
constexpr int kHeight = 270;

float Uniform(std::mt19937& rng, float lo, float hi) {
  return std::uniform_real_distribution<float>(lo, hi)(rng);
}

int UniformInt(std::mt19937& rng, int lo, int hi) {
  return std::uniform_int_distribution<int>(lo, hi)(rng);
}

// Non-negative rows of unit L2 norm, like SIFT descriptors, as a map holds them (bytes).
void FillUnitRows(std::mt19937& rng, DescriptorBytes* m) {
  Eigen::Matrix<float, 1, kDescriptorSize> row;
  for (Eigen::Index i = 0; i < m->rows(); ++i) {
    for (int j = 0; j < kDescriptorSize; ++j) row[j] = Uniform(rng, 0.0f, 1.0f);
    row.normalize();
    for (int j = 0; j < kDescriptorSize; ++j) (*m)(i, j) = UnitByte(row[j]);
  }
}

void FillDescriptors(std::mt19937& rng, Map* map) {
  const int l = map->num_landmarks();
  FillUnitRows(rng, &map->local_mean);
  FillUnitRows(rng, &map->context_mean);
  map->context_dmax.resize(l, kNumHistograms);
  map->context_var.resize(l, kNumHistograms);
  for (int i = 0; i < l; ++i) {
    map->local_dmax.push_back(Uniform(rng, 0.1f, 0.6f));
    map->local_var.push_back(Uniform(rng, 0.02f, 0.1f));
    map->quality.push_back(Uniform(rng, 0.0f, 5.0f));
    for (int h = 0; h < kNumHistograms; ++h) {
      map->context_dmax(i, h) = ContextSpreadCode().Encode(Uniform(rng, 0.0f, 0.3f));
      map->context_var(i, h) = ContextSpreadCode().Encode(Uniform(rng, 0.002f, 0.05f));
    }
  }
}

// Each landmark: a track over consecutive images, jittering around one point.
void FillObservations(std::mt19937& rng, Map* map) {
  const int n = map->num_images();
  map->observation_offsets.push_back(0);
  for (int g = 0; g < map->num_landmarks(); ++g) {
    const int length = UniformInt(rng, std::min(2, n), std::min(5, n));
    const int first = UniformInt(rng, 0, n - length);
    const float x = Uniform(rng, 0.0f, kWidth), y = Uniform(rng, 0.0f, kHeight);
    for (int k = 0; k < length; ++k) {
      map->AddObservation(static_cast<uint32_t>(first + k), x + Uniform(rng, -3.0f, 3.0f),
                          y + Uniform(rng, -3.0f, 3.0f), Uniform(rng, 2.0f, 20.0f),
                          Uniform(rng, 0.0f, 360.0f));
    }
    map->observation_offsets.push_back(static_cast<uint32_t>(map->observation_image.size()));
  }
}

// G_l: the landmarks seen in each image, in landmark order.
void FillImageLists(Map* map) {
  std::vector<std::vector<uint32_t>> lists(map->num_images());
  for (int g = 0; g < map->num_landmarks(); ++g) {
    for (uint32_t j = map->observation_offsets[g]; j < map->observation_offsets[g + 1]; ++j) {
      lists[map->observation_image[j]].push_back(static_cast<uint32_t>(g));
    }
  }
  map->image_offsets.push_back(0);
  for (const std::vector<uint32_t>& list : lists) {
    map->image_landmarks.insert(map->image_landmarks.end(), list.begin(), list.end());
    map->image_offsets.push_back(static_cast<uint32_t>(map->image_landmarks.size()));
  }
}

// Landmarks sharing an image with g, each with the number of images shared.
std::vector<std::pair<uint32_t, int>> CoOccurring(const Map& map, int g, std::vector<int>* shared) {
  std::vector<std::pair<uint32_t, int>> result;
  std::vector<uint32_t> seen;
  for (uint32_t j = map.observation_offsets[g]; j < map.observation_offsets[g + 1]; ++j) {
    const uint32_t image = map.observation_image[j];
    for (uint32_t k = map.image_offsets[image]; k < map.image_offsets[image + 1]; ++k) {
      const uint32_t other = map.image_landmarks[k];
      if (other == static_cast<uint32_t>(g)) continue;
      if ((*shared)[other]++ == 0) seen.push_back(other);
    }
  }
  for (uint32_t other : seen) {
    result.emplace_back(other, (*shared)[other]);
    (*shared)[other] = 0;
  }
  return result;
}

Neighbour MakeNeighbour(std::mt19937& rng, const Map& map, int g, uint32_t other, int shared) {
  const float dx = map.MeanPosition(static_cast<int>(other))[0] - map.MeanPosition(g)[0];
  const float dy = map.MeanPosition(static_cast<int>(other))[1] - map.MeanPosition(g)[1];
  Neighbour n;
  n.landmark = other;
  n.cooccurrence = static_cast<float>(shared) /
                   static_cast<float>(map.observation_offsets[g + 1] - map.observation_offsets[g]);
  n.distance_mean = std::hypot(dx, dy);
  n.distance_var = 100.0f + Uniform(rng, 0.0f, 50.0f);
  n.distance_dmax = Uniform(rng, 0.0f, 10.0f);
  n.angle_mean = std::atan2(dy, dx);
  n.angle_var = 0.01f + Uniform(rng, 0.0f, 0.1f);
  n.angle_dmax = Uniform(rng, 0.0f, 0.5f);
  return n;
}

void FillNeighbours(std::mt19937& rng, Map* map) {
  std::vector<int> shared(map->num_landmarks(), 0);
  map->neighbour_offsets.push_back(0);
  for (int g = 0; g < map->num_landmarks(); ++g) {
    std::vector<Neighbour> list;
    for (const auto& [other, count] : CoOccurring(*map, g, &shared)) {
      list.push_back(MakeNeighbour(rng, *map, g, other, count));
    }
    std::sort(list.begin(), list.end(), [](const Neighbour& a, const Neighbour& b) {
      return a.distance_mean < b.distance_mean ||
             (a.distance_mean == b.distance_mean && a.landmark < b.landmark);
    });
    list.resize(std::min<size_t>(list.size(), map->options.max_neighbours));
    for (const Neighbour& n : list) map->neighbours.push_back(Pack(n, kWidth));
    map->neighbour_offsets.push_back(static_cast<uint32_t>(map->neighbours.size()));
  }
}

void FillHeader(int num_images, uint32_t seed, Map* map) {
  map->provenance.tour_dir = "tours/random_" + std::to_string(seed);
  map->provenance.created_utc = "2024-05-01T12:00:00Z";
  map->provenance.tool_version = "test";
  for (int i = 0; i < num_images; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%05d.jpg", i);
    map->image_names.push_back(name);
  }
  map->image_width = kWidth;
  map->image_height = kHeight;
}

// A holistic descriptor per tour image on the default grid of the frame.
void FillHolistic(std::mt19937& rng, Map* map) {
  map->holistic_grid = GridForFrame(kWidth, kHeight, map->options.extractor.holistic);
  for (int i = 0; i < map->num_images() * map->holistic_grid.size(); ++i) {
    map->holistic.push_back(UnitByte(Uniform(rng, 0.0f, 0.45f)));
  }
}

}  // namespace

Eigen::Matrix<uint8_t, 1, kDescriptorSize> DescriptorBytesOf(
    const Eigen::Matrix<float, 1, kDescriptorSize>& values) {
  Eigen::Matrix<uint8_t, 1, kDescriptorSize> bytes;
  for (int i = 0; i < kDescriptorSize; ++i) bytes[i] = UnitByte(values[i]);
  return bytes;
}

Map MakeRandomMap(int num_images, int num_landmarks, uint32_t seed) {
  std::mt19937 rng(seed);
  Map map;
  FillHeader(num_images, seed, &map);
  FillHolistic(rng, &map);
  map.calibration = {true, Uniform(rng, 0.2f, 0.4f), Uniform(rng, 0.01f, 0.05f),
                     static_cast<uint32_t>(num_images)};
  map.local_mean.resize(num_landmarks, kDescriptorSize);
  map.context_mean.resize(num_landmarks, kDescriptorSize);
  FillDescriptors(rng, &map);
  FillObservations(rng, &map);
  FillImageLists(&map);
  FillNeighbours(rng, &map);
  map.provenance.num_features = static_cast<uint32_t>(map.observation_image.size() * 3);
  map.provenance.num_tracks = static_cast<uint32_t>(num_landmarks * 2);
  map.provenance.num_candidates = static_cast<uint32_t>(num_landmarks);
  if (Status status = map.Validate(); !status.ok()) {
    std::fprintf(stderr, "MakeRandomMap made an invalid map: %s\n", status.ToString().c_str());
    std::abort();
  }
  map.Finalize();
  return map;
}

namespace {

void ExpectOptionsEqual(const TrainOptions& a, const TrainOptions& b) {
  EXPECT_EQ(a.extractor.max_features, b.extractor.max_features);
  EXPECT_EQ(a.extractor.working_size, b.extractor.working_size);
  EXPECT_EQ(a.extractor.context_scale, b.extractor.context_scale);
  EXPECT_EQ(a.extractor.contrast_threshold, b.extractor.contrast_threshold);
  EXPECT_EQ(a.extractor.edge_threshold, b.extractor.edge_threshold);
  EXPECT_EQ(a.extractor.sigma, b.extractor.sigma);
  EXPECT_EQ(a.extractor.octave_layers, b.extractor.octave_layers);
  EXPECT_EQ(a.extractor.max_image_side, b.extractor.max_image_side);
  EXPECT_EQ(a.extractor.clahe_clip, b.extractor.clahe_clip);
  EXPECT_EQ(a.extractor.root_sift, b.extractor.root_sift);
  EXPECT_EQ(a.extractor.holistic.cols, b.extractor.holistic.cols);
  EXPECT_EQ(a.extractor.holistic.cell_pixels, b.extractor.holistic.cell_pixels);
  EXPECT_EQ(a.extractor.holistic.bins, b.extractor.holistic.bins);
  EXPECT_EQ(a.extractor.holistic.max_shift, b.extractor.holistic.max_shift);
  EXPECT_EQ(a.track_distance_threshold, b.track_distance_threshold);
  EXPECT_EQ(a.ransac_threshold, b.ransac_threshold);
  EXPECT_EQ(a.ransac_confidence, b.ransac_confidence);
  EXPECT_EQ(a.min_links_per_pair, b.min_links_per_pair);
  EXPECT_EQ(a.min_track_length, b.min_track_length);
  EXPECT_EQ(a.min_landmarks_per_image, b.min_landmarks_per_image);
  EXPECT_EQ(a.local_var_floor, b.local_var_floor);
  EXPECT_EQ(a.context_var_floor, b.context_var_floor);
  EXPECT_EQ(a.distance_sd_floor, b.distance_sd_floor);
  EXPECT_EQ(a.angle_var_floor, b.angle_var_floor);
  EXPECT_EQ(a.quality_s_min, b.quality_s_min);
  EXPECT_EQ(a.quality_fp_prior, b.quality_fp_prior);
  EXPECT_EQ(a.eta, b.eta);
  EXPECT_EQ(a.q_min, b.q_min);
  EXPECT_EQ(a.quality_window, b.quality_window);
  EXPECT_EQ(a.place_index_min_locations, b.place_index_min_locations);
  EXPECT_EQ(a.max_neighbours, b.max_neighbours);
  EXPECT_EQ(a.tolerance, b.tolerance);
  EXPECT_EQ(a.confidence_temperature, b.confidence_temperature);
  EXPECT_EQ(a.map_evidence_slope, b.map_evidence_slope);
  EXPECT_EQ(a.map_evidence_offset, b.map_evidence_offset);
}

template <typename Matrix>
void ExpectMatricesEqual(const char* name, const Matrix& a, const Matrix& b) {
  ASSERT_EQ(a.rows(), b.rows()) << name;
  ASSERT_EQ(a.cols(), b.cols()) << name;
  const size_t bytes = static_cast<size_t>(a.size()) * sizeof(typename Matrix::Scalar);
  EXPECT_TRUE(bytes == 0 || std::memcmp(a.data(), b.data(), bytes) == 0) << name << " differs";
}

template <typename T>
void ExpectArraysEqual(const char* name, const std::vector<T>& a, const std::vector<T>& b) {
  ASSERT_EQ(a.size(), b.size()) << name;
  EXPECT_TRUE(a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0)
      << name << " differs";
}

}  // namespace

void ExpectMapsEqual(const Map& a, const Map& b) {
  ExpectOptionsEqual(a.options, b.options);
  EXPECT_EQ(a.provenance.tour_dir, b.provenance.tour_dir);
  EXPECT_EQ(a.provenance.created_utc, b.provenance.created_utc);
  EXPECT_EQ(a.provenance.tool_version, b.provenance.tool_version);
  EXPECT_EQ(a.provenance.num_features, b.provenance.num_features);
  EXPECT_EQ(a.provenance.num_tracks, b.provenance.num_tracks);
  EXPECT_EQ(a.provenance.num_candidates, b.provenance.num_candidates);
  EXPECT_EQ(a.calibration.valid, b.calibration.valid);
  EXPECT_EQ(a.calibration.off_map_distance, b.calibration.off_map_distance);
  EXPECT_EQ(a.calibration.off_map_spread, b.calibration.off_map_spread);
  EXPECT_EQ(a.calibration.samples, b.calibration.samples);
  EXPECT_EQ(a.image_names, b.image_names);
  EXPECT_EQ(a.image_width, b.image_width);
  EXPECT_EQ(a.image_height, b.image_height);
  EXPECT_TRUE(a.holistic_grid == b.holistic_grid);
  ExpectArraysEqual("holistic", a.holistic, b.holistic);
  ExpectMatricesEqual("local_mean", a.local_mean, b.local_mean);
  ExpectArraysEqual("local_dmax", a.local_dmax, b.local_dmax);
  ExpectArraysEqual("local_var", a.local_var, b.local_var);
  ExpectMatricesEqual("context_mean", a.context_mean, b.context_mean);
  ExpectMatricesEqual("context_dmax", a.context_dmax, b.context_dmax);
  ExpectMatricesEqual("context_var", a.context_var, b.context_var);
  ExpectArraysEqual("quality", a.quality, b.quality);
  ExpectArraysEqual("observation_offsets", a.observation_offsets, b.observation_offsets);
  ExpectArraysEqual("observation_image", a.observation_image, b.observation_image);
  ExpectArraysEqual("observations", a.observations, b.observations);
  EXPECT_EQ(a.observation_angles, b.observation_angles);
  ExpectArraysEqual("neighbour_offsets", a.neighbour_offsets, b.neighbour_offsets);
  ExpectArraysEqual("neighbours", a.neighbours, b.neighbours);
  ExpectArraysEqual("image_offsets", a.image_offsets, b.image_offsets);
  ExpectArraysEqual("image_landmarks", a.image_landmarks, b.image_landmarks);
  ExpectArraysEqual("lookalike_offsets", a.lookalike_offsets, b.lookalike_offsets);
  ExpectArraysEqual("lookalike_location", a.lookalike_location, b.lookalike_location);
  ExpectArraysEqual("lookalike_ratio", a.lookalike_ratio, b.lookalike_ratio);
  ExpectArraysEqual("image_place", a.image_place, b.image_place);
  ExpectArraysEqual("place_image", a.place_image, b.place_image);
  ASSERT_EQ(a.experiences.size(), b.experiences.size());
  for (size_t e = 0; e < a.experiences.size(); ++e) {
    const Experience &x = a.experiences[e], &y = b.experiences[e];
    EXPECT_EQ(x.name, y.name) << e;
    EXPECT_EQ(x.source_dir, y.source_dir) << e;
    EXPECT_EQ(x.created_utc, y.created_utc) << e;
    EXPECT_EQ(x.kind, y.kind) << e;
    EXPECT_EQ(x.first_image, y.first_image) << e;
    EXPECT_EQ(x.num_images, y.num_images) << e;
    EXPECT_EQ(x.walk_frames, y.walk_frames) << e;
    EXPECT_EQ(x.calibration.valid, y.calibration.valid) << e;
    EXPECT_EQ(x.calibration.samples, y.calibration.samples) << e;
    EXPECT_EQ(x.calibration.off_map_distance, y.calibration.off_map_distance) << e;
    EXPECT_EQ(x.calibration.off_map_spread, y.calibration.off_map_spread) << e;
  }
  ExpectArraysEqual("local_mean_sqnorm", a.local_mean_sqnorm, b.local_mean_sqnorm);
  const PlaceIndex &p = a.place_index, &q = b.place_index;
  EXPECT_EQ(p.vocabulary.coarse, q.vocabulary.coarse);
  EXPECT_EQ(p.vocabulary.fine, q.vocabulary.fine);
  EXPECT_TRUE(p.vocabulary.centroids == q.vocabulary.centroids);
  ExpectArraysEqual("landmark_word", p.landmark_word, q.landmark_word);
  EXPECT_EQ(p.holistic.bins, q.holistic.bins);
  ExpectArraysEqual("holistic_codebook", p.holistic.codebook, q.holistic.codebook);
  ExpectArraysEqual("holistic_codes", p.holistic.codes, q.holistic.codes);
}

}  // namespace sceneloc::test
