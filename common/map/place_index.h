// The place index of a map: what the coarse stage of recognition needs to pick, from a
// map of any size, the few tour locations a query can be at, so that the paper's S_D * S_N,
// the likelihood and verification run over those alone (common/matching/place_search.h).
// This is our departure from the paper, whose every query scores every landmark: the
// coarse-to-fine pattern of retrieval at scale (an inverted file of visual words, as DBoW2
// and FAB-MAP 2.0 use, and a global descriptor, as hloc does), here with both of the
// evidence kinds sceneloc already fuses:
//
//   - a vocabulary of visual words over the landmarks' local descriptors (two levels of
//     k-means: `coarse` cells of `fine` words each) and the word of every landmark: a
//     query's features vote, through an inverted file, for the locations whose landmarks
//     share their words (tf-idf);
//   - the holistic descriptor of every location with each of its cells coded as one byte
//     (HolisticCodes): a query's approximate holistic distance to every location, at every
//     lateral shift the holistic comparison allows, costs one table look-up a cell instead
//     of a dozen multiply-adds.
//
// Built at training (common/training/place_index_builder.h) and stored in the map; the
// inverted file is derived when the map is finalised. A map without one (small maps, maps
// of format versions older than 4) is searched whole.
//
// Thread-safe once built: read-only.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "common/features/feature_set.h"
#include "common/util/status.h"
#include "common/util/thread_pool.h"

namespace sceneloc {

// Visual words: word w = c * fine + f is fine centroid f of coarse cell c.
struct Vocabulary {
  int coarse = 0;  // coarse cells
  int fine = 0;    // words per cell
  // coarse rows of coarse centroids, then coarse x fine rows of word centroids.
  DescriptorMatrix centroids;

  int num_words() const { return coarse * fine; }
  bool empty() const { return coarse == 0; }
};

// The holistic descriptors of a tour, every cell coded as the nearest of kHolisticCodes cell
// histograms fitted on the tour's cells: product quantisation with the grid's cells as the
// subspaces (Jegou, Douze & Schmid, "Product quantization for nearest neighbor search",
// PAMI 2011). A query's distance to a location, at every lateral shift, is then one table
// look-up per cell (common/matching/place_search.h). Unlike principal axes of the tour's
// descriptors, which keep what most of the map varies in and lose the rest (on a map that
// is mostly another route, most of what tells this route's places apart), a cell's code
// errs by the same small amount whatever the rest of the map holds.
inline constexpr int kHolisticCodes = 256;  // one byte a cell
struct HolisticCodes {
  int bins = 0;                 // values per cell: the grid's orientation bins
  std::vector<float> codebook;  // kHolisticCodes x bins, code after code
  std::vector<uint8_t> codes;   // per location, per cell (row after row): the cell's code

  bool empty() const { return codebook.empty(); }
};

// Rows of values, as k-means reads and writes them.
using RowMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Lloyd's k-means of the rows of `x` into k centres (k <= rows) over `iterations` rounds,
// seeded by k distinct rows drawn with `rng`; an emptied centre is moved to the row
// furthest from its own.
RowMatrix KMeans(const RowMatrix& x, int k, int iterations, std::mt19937* rng);

// The codes of `n` tour descriptors on `grid`, stored as unit bytes (Map::holistic): the
// codebook by Lloyd's k-means over at most 65,536 of their cells (evenly sampled, seeded:
// the same descriptors give the same codes), then every cell's nearest code. Empty for an
// empty grid. `pool` (may be null) spreads the coding.
HolisticCodes CodeHolistic(const std::vector<uint8_t>& holistic, const HolisticGrid& grid, size_t n,
                           ThreadPool* pool);

// The codes of cells [first, first + count) of `holistic` (unit bytes, cell after cell) on the
// codebook of `codes` (its bins and codebook; its codes are not read): the nearest code of
// each, as CodeHolistic codes them. A map extended by walks codes its new images so, on the
// codebook its tour learnt. REQUIRES: !codes.empty(), the cells within `holistic`.
std::vector<uint8_t> CodeCells(const std::vector<uint8_t>& holistic, size_t first, size_t count,
                               const HolisticCodes& codes, ThreadPool* pool);

struct PlaceIndex {
  Vocabulary vocabulary;
  std::vector<uint32_t> landmark_word;  // one per landmark
  // Empty in a map read from format versions 4-7 until the map is finalised (Map::Finalize
  // codes its holistic descriptors then).
  HolisticCodes holistic;

  bool empty() const { return vocabulary.empty(); }
};

// Checks an index against the map it belongs to (its landmark and location counts and its
// holistic grid): sizes, word numbers in range, finite values. An empty index passes.
Status ValidatePlaceIndex(const PlaceIndex& index, size_t num_landmarks, size_t num_locations,
                          const HolisticGrid& grid);

// A Hamming embedding of the visual words (Jegou, Douze & Schmid, "Hamming embedding and
// weak geometric consistency for large scale image search", ECCV 2008): a word is a coarse
// cell of descriptor space, so two descriptors that share one may still be far apart. Each
// descriptor also gets a 64-bit signature: its projection on 64 fixed random orthonormal
// axes, each bit set where the value passes the median of the word's landmarks on that
// axis. Two descriptors of one word whose signatures differ in few bits are near; a word
// match counts only within a Hamming distance (MatchOptions::place_hamming_max).
inline constexpr int kSignatureBits = 64;
using SignatureProjection = Eigen::Matrix<float, kSignatureBits, kDescriptorSize, Eigen::RowMajor>;

// The projection's axes: a fixed seed's random signs, orthonormalised (the same on every
// machine: integer draws and IEEE arithmetic).
SignatureProjection MakeSignatureProjection();

// The inverted file of an index: for each word, every occurrence of one of its landmarks
// in a location's G_l, with the landmark's signature. Derived when a map is finalised (from
// the landmarks' words and mean descriptors), so maps of every format with a place index
// have it.
struct InvertedFile {
  std::vector<uint32_t> offsets;    // words + 1
  std::vector<uint32_t> location;   // per occurrence
  std::vector<uint64_t> signature;  // per occurrence: its landmark's
  std::vector<float> idf;           // per word: log(locations / locations with it); 0 if none
  // Per location: 1 / the norm of its tf-idf vector (0 for a location without landmarks).
  std::vector<float> location_scale;
  SignatureProjection projection;
  std::vector<float> thresholds;  // words x kSignatureBits: the per-word medians
};
// `means`: the landmarks' mean local descriptors as bytes (Map::local_mean).
InvertedFile BuildInvertedFile(
    const PlaceIndex& index, const std::vector<uint32_t>& image_offsets,
    const std::vector<uint32_t>& image_landmarks,
    const Eigen::Matrix<uint8_t, Eigen::Dynamic, kDescriptorSize, Eigen::RowMajor>& means);

// The signature of each row of `descriptors` (values, as FeatureSet::local) in its word.
std::vector<uint64_t> Signatures(const InvertedFile& file, const DescriptorMatrix& descriptors,
                                 const std::vector<uint32_t>& words);

// The coarse cell of each row of `descriptors`: the nearest of the first vocabulary.coarse
// centroids (which is all the training's first level has).
// REQUIRES: !vocabulary.empty().
std::vector<uint32_t> AssignCells(const Vocabulary& vocabulary,
                                  const DescriptorMatrix& descriptors);

// The word of each row of `descriptors`: the nearest word of the nearest coarse cell.
// REQUIRES: !vocabulary.empty() and every cell's words present.
std::vector<uint32_t> AssignWords(const Vocabulary& vocabulary,
                                  const DescriptorMatrix& descriptors);

}  // namespace sceneloc
