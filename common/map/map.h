// The landmark map: what sceneloc-train writes, a map file holds, and the matcher reads.
//
// Landmarks are stored as structure-of-arrays so the matcher can run matrix products over
// whole blocks of them. Variable-length per-landmark data (where a landmark was seen, its
// neighbours) and per-image landmark lists are CSR: an offsets array of size count + 1
// and one flat array of entries.
//
// Thread-safe once built: a Map is immutable after Finalize(); the server shares it as
// std::shared_ptr<const Map> between concurrent requests.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/map/compact.h"
#include "common/map/place_index.h"
#include "common/map/train_options.h"
#include "common/util/status.h"

namespace sceneloc {

// Descriptors as bytes (UnitByte, compact.h), one row per landmark.
using DescriptorBytes = Eigen::Matrix<uint8_t, Eigen::Dynamic, kDescriptorSize, Eigen::RowMajor>;
// Per-histogram spreads as bytes (ContextSpreadCode, compact.h), one row per landmark.
using HistogramCodes = Eigen::Matrix<uint8_t, Eigen::Dynamic, kNumHistograms, Eigen::RowMajor>;

// Dimensions of the projection S_D's lower bound uses (Map::local_basis): a quarter of the
// descriptor's, where the bound lets through about 4% of pairs against 0.7% that pass
// (measured on the Gardens Point map, docs/results.md).
inline constexpr int kBoundDims = 32;
using ProjectedMatrix = Eigen::Matrix<float, Eigen::Dynamic, kBoundDims, Eigen::RowMajor>;

// What the calibrated confidence (common/matching/confidence.h) needs from the tour,
// measured at training time: how close a frame that shows no place of the route comes to
// the tour's images (the tour's own frames turned upside down, localised against the map).
struct Calibration {
  bool valid = false;          // false: a map without calibration (format version 1)
  float off_map_distance = 0;  // median smallest holistic distance of such frames
  float off_map_spread = 0;    // 1.4826 MAD of those distances (> 0)
  uint32_t samples = 0;        // how many frames were measured
};

// Where and how a map was made.
struct MapProvenance {
  std::string tour_dir;         // the tour folder as given to sceneloc-train
  std::string created_utc;      // ISO 8601
  std::string tool_version;     // sceneloc version that wrote it
  uint32_t num_features = 0;    // features extracted over the whole tour
  uint32_t num_tracks = 0;      // tracks of length >= 2 (landmark candidates)
  uint32_t num_candidates = 0;  // landmarks before selection
};

// One walk that made part of a map (an experience): the tour it was trained from, or a walk
// added to it later (sceneloc-train --extend, common/training/extend.h).
enum class ExperienceKind : uint32_t {
  kTour = 0,       // the walk the map was trained from: its images are the first places
  kRoute = 1,      // the route again under other conditions: each image is another view of
                   // the place the walk was aligned to
  kNewGround = 2,  // ground the map did not cover: each image is a new place
};
const char* ExperienceKindName(ExperienceKind kind);

struct Experience {
  std::string name;         // the walk's name (its folder's, unless given)
  std::string source_dir;   // the folder as given
  std::string created_utc;  // ISO 8601
  ExperienceKind kind = ExperienceKind::kTour;
  // Its images are [first_image, first_image + num_images) of the map's.
  uint32_t first_image = 0;
  uint32_t num_images = 0;
  // Frames the walk had: those the map recognised with confidence added nothing.
  uint32_t walk_frames = 0;
  // The walk's own off-map level (its images against themselves): how likely a frame is to
  // show this walk's ground, the others' aside (confidence.h WalkInMapProbability).
  Calibration calibration;
};

struct Map {
  TrainOptions options;
  MapProvenance provenance;
  Calibration calibration;

  // Tour images, walk after walk (experiences), each walk in its order.
  std::vector<std::string> image_names;
  // Places (the locations an answer names) and images: image i shows place image_place[i].
  // Empty: one image per place, image i is place i (a map of one walk, format versions 1-8).
  // A place's name is its first image's. Places are numbered along the route: the tour's
  // images are places 0..N-1, new ground follows.
  std::vector<uint32_t> image_place;
  // The walks the images came from, in image order, covering every image; empty in maps of
  // format versions 1-8 (one walk, the tour).
  std::vector<Experience> experiences;
  int image_width = 0;  // working frame of the tour images (extractor.h), pixels
  int image_height = 0;
  // Holistic descriptor of every tour image (holistic.h): N x holistic_grid.size() values as
  // bytes (UnitByte), image after image. Both empty in maps made without one (format
  // version 1).
  HolisticGrid holistic_grid;
  std::vector<uint8_t> holistic;

  // --- Landmarks: L rows each ---
  DescriptorBytes local_mean;     // mu of the local descriptor
  std::vector<float> local_dmax;  // d_max
  std::vector<float> local_var;   // sigma^2 (floored)
  DescriptorBytes context_mean;   // mu of the context descriptor (16 histograms x 8)
  HistogramCodes context_dmax;    // d_max per histogram
  HistogramCodes context_var;     // sigma^2 per histogram (floored; code > 0)
  std::vector<float> quality;     // Q (eq. 4)

  // Observations (CSR over landmarks): the tour images a landmark was seen in and where:
  // the keypoint's position, size (diameter, pixels) and orientation there (degrees in
  // [0, 360), OpenCV's convention; observation_angles false: not known, in maps of format
  // version 1).
  std::vector<uint32_t> observation_offsets;  // L + 1
  std::vector<uint32_t> observation_image;
  std::vector<PackedObservation> observations;
  bool observation_angles = true;

  // Neighbours (CSR over landmarks), sorted by distance from the landmark's mean position;
  // NeighbourAt reads one.
  std::vector<uint32_t> neighbour_offsets;  // L + 1
  std::vector<PackedNeighbour> neighbours;

  // G_l (CSR over tour images): the selected landmarks seen in each tour image.
  std::vector<uint32_t> image_offsets;  // N + 1
  std::vector<uint32_t> image_landmarks;

  // The coarse stage's index (place_index.h); empty in maps searched whole.
  PlaceIndex place_index;

  // Look-alikes (CSR over places; common/training/lookalikes.h): the places elsewhere
  // on the route that a place's frame verifies against, each with how much of the
  // image's own verified evidence it reaches (in (0, 1]). The confidence reads the evidence
  // of an answer's look-alikes as weaker than that of distinct places. All three empty in
  // maps made without them (format versions 1-6).
  std::vector<uint32_t> lookalike_offsets;  // N + 1
  std::vector<uint32_t> lookalike_location;
  std::vector<float> lookalike_ratio;

  // --- Derived by Finalize(), not stored ---
  std::vector<float> local_mean_sqnorm;  // |mu|^2 per landmark
  // S_D's lower bound (descriptor_similarity.cc): P, the kBoundDims principal axes of the
  // local means (uncentred; orthonormal columns), and per landmark P^T mu, |P^T mu|^2 and
  // the norm of the rest, |mu - P P^T mu|. For any descriptor a,
  //   |a - mu|^2 >= |P^T a - P^T mu|^2 + (|a - P P^T a| - |mu - P P^T mu|)^2.
  // The projections are kept only in maps searched whole (no place index); the coarse stage
  // projects its scope's landmarks itself (descriptor_similarity.cc), so big maps do not hold
  // 140 bytes more per landmark.
  Eigen::Matrix<float, kDescriptorSize, kBoundDims> local_basis;
  ProjectedMatrix local_projected;
  std::vector<float> local_projected_sqnorm;
  std::vector<float> local_residual_norm;
  // The place index's inverted file (empty without one).
  InvertedFile inverted_file;
  // The first image of every place (its name's); empty when image i is place i.
  std::vector<uint32_t> place_image;

  int num_landmarks() const { return static_cast<int>(local_mean.rows()); }
  int num_images() const { return static_cast<int>(image_names.size()); }
  // Places: what answers, tolerances, the confidence and sessions count in.
  int num_places() const {
    return image_place.empty() ? num_images() : static_cast<int>(place_image.size());
  }
  int PlaceOf(int image) const { return image_place.empty() ? image : int(image_place[image]); }
  const std::string& PlaceName(int place) const {
    return image_place.empty() ? image_names[place] : image_names[place_image[place]];
  }
  // Every place's name, in place order.
  std::vector<std::string> PlaceNames() const;
  // What a robot's session is kept against (server/session_token.h): a CRC-32 of the map's
  // tour (its first walk's creation time and name) and of its places' names in order. The
  // same for every version of a map that keeps its places (one extended by a walk of its
  // route, or reloaded as it was); another for a map retrained, of another tour, or with new
  // ground added. REQUIRES: Finalize()d.
  uint32_t PlacesKey() const;
  bool has_holistic() const { return !holistic_grid.empty(); }
  bool has_place_index() const { return !place_index.empty(); }
  bool has_lookalikes() const { return !lookalike_offsets.empty(); }
  const uint8_t* holistic_of(int image) const {
    return holistic.data() + static_cast<size_t>(image) * holistic_grid.size();
  }
  // The holistic descriptor of tour image `image` as values.
  std::vector<float> HolisticValues(int image) const;
  // The mean local (context) descriptor of landmark g as values, into out[0, 128).
  void LocalMean(int g, float* out) const;
  void ContextMean(int g, float* out) const;
  Eigen::Matrix<float, 1, kDescriptorSize> LocalMeanRow(int g) const {
    Eigen::Matrix<float, 1, kDescriptorSize> row;
    LocalMean(g, row.data());
    return row;
  }
  Eigen::Matrix<float, 1, kDescriptorSize> ContextMeanRow(int g) const {
    Eigen::Matrix<float, 1, kDescriptorSize> row;
    ContextMean(g, row.data());
    return row;
  }
  // Landmark g's mean position over its observations (x, y), pixels.
  std::array<float, 2> MeanPosition(int g) const;
  // Observation o's keypoint.
  float ObservationX(size_t o) const { return observations[o].X(); }
  float ObservationY(size_t o) const { return observations[o].Y(); }
  float ObservationSize(size_t o) const { return observations[o].Size(); }
  float ObservationAngle(size_t o) const { return observations[o].Angle(); }
  void AddObservation(uint32_t image, float x, float y, float size, float angle_deg) {
    observation_image.push_back(image);
    observations.push_back(PackObservation(x, y, size, angle_deg));
  }
  float ContextDmax(int g, int h) const { return ContextSpreadCode().Decode(context_dmax(g, h)); }
  float ContextVar(int g, int h) const { return ContextSpreadCode().Decode(context_var(g, h)); }
  // Neighbour k of the neighbour list (neighbours[k]) as S_N reads it.
  Neighbour NeighbourAt(size_t k) const {
    return Unpack(neighbours[k], static_cast<float>(frame_long_side()));
  }
  // Whether Finalize keeps the projections (a map searched whole).
  bool keeps_projections() const { return !has_place_index(); }
  // The long side of the working frame: pixel-unit settings are fractions of it.
  int frame_long_side() const { return std::max(image_width, image_height); }
  // Where a query image of width x height is extracted to be matched against this map.
  ExtractionTarget QueryTarget(int width, int height) const {
    return sceneloc::QueryTarget(width, height, image_width, holistic_grid);
  }

  // Checks every count and index for consistency; a map that passes can be matched
  // against without further bounds checks. Errors name the first inconsistency.
  Status Validate() const;
  // Computes the derived fields, and the holistic codes of a place index read from format
  // versions 4-7 (place_index.h). REQUIRES: Validate().ok().
  void Finalize();
  // Approximate heap bytes held by this map.
  size_t MemoryBytes() const;
};

// The projections of `means` (values, one row per landmark) onto `basis`, into rows
// [at, at + means.rows()) of `projected`, with their squared norms and the norms of what the
// basis leaves out, into the same entries of `sqnorm` and `residual_norm`: what S_D's lower
// bound reads of a landmark (Map::local_projected). REQUIRES: room for those rows.
void ProjectBlock(const DescriptorMatrix& means,
                  const Eigen::Matrix<float, kDescriptorSize, kBoundDims>& basis,
                  ProjectedMatrix* projected, Eigen::Index at, std::vector<float>* sqnorm,
                  std::vector<float>* residual_norm);

}  // namespace sceneloc
