// The features of a training tour, read a window of consecutive images at a time, so that
// training holds what one stage needs rather than the whole tour (20,000 images of ~900
// features are ~19 GB as floats).
//
// Two sources: a tour already in memory (TourInMemory: the accuracy suite, tests) and a
// spool on disk that extraction appends to in tour order (FeatureSpool: sceneloc-train).
// Both hand out exactly the floats they were given, so training reads the same numbers
// either way.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/features/feature_set.h"
#include "common/util/status.h"

namespace sceneloc {

// The feature sets of tour images [first, first + size()), indexed by tour image.
// Either owns its sets (read from a spool) or views a tour held elsewhere, which must then
// outlive it. Movable; read-only once made, so any number of threads may read it.
class TourWindow {
 public:
  TourWindow() = default;
  // A view of sets[0, count) as tour images [first, first + count).
  TourWindow(size_t first, const FeatureSet* sets, size_t count)
      : first_(first), sets_(sets), count_(count) {}
  // Owns `sets` as tour images [first, first + sets.size()).
  TourWindow(size_t first, std::vector<FeatureSet> sets)
      : first_(first), owned_(std::move(sets)), sets_(owned_.data()), count_(owned_.size()) {}
  TourWindow(TourWindow&&) = default;
  TourWindow& operator=(TourWindow&&) = default;

  size_t first() const { return first_; }
  size_t end() const { return first_ + count_; }
  size_t size() const { return count_; }
  bool Holds(size_t image) const { return image >= first_ && image < end(); }
  // REQUIRES: Holds(image).
  const FeatureSet& operator[](size_t image) const { return sets_[image - first_]; }

 private:
  size_t first_ = 0;
  std::vector<FeatureSet> owned_;  // empty for a view (its buffer stays put when moved)
  const FeatureSet* sets_ = nullptr;
  size_t count_ = 0;
};

// A whole tour in memory as a window of images [0, tour.size()).
TourWindow WholeTour(const std::vector<FeatureSet>& tour);

// Where training reads a tour's features from. Window() may be called from any thread.
class TourFeatures {
 public:
  virtual ~TourFeatures() = default;
  virtual size_t size() const = 0;
  // The features of images [begin, end). Errors: a read that fails (IoError).
  // REQUIRES: begin <= end <= size().
  virtual StatusOr<TourWindow> Window(size_t begin, size_t end) const = 0;
};

// A tour held in memory; `tour` must outlive it. Windows are views, never copies.
class TourInMemory : public TourFeatures {
 public:
  explicit TourInMemory(const std::vector<FeatureSet>& tour) : tour_(tour) {}
  size_t size() const override { return tour_.size(); }
  StatusOr<TourWindow> Window(size_t begin, size_t end) const override;

 private:
  const std::vector<FeatureSet>& tour_;
};

// A tour's features in a temporary file, written once in tour order and read back in
// windows. The file has no name (it is unlinked as soon as it is made), so nothing is left
// behind however the process ends. Holds in memory only each image's offset.
// Thread-safety: Append from one thread, with no Window call at the same time; once the
// tour is appended, Window from any number of threads.
class FeatureSpool : public TourFeatures {
 public:
  // A spool in folder `dir` (its free space bounds the tour: about 1 MB per image of 1,000
  // features). Errors: the folder cannot hold a file (IoError, naming it).
  static StatusOr<std::unique_ptr<FeatureSpool>> Create(const std::string& dir);
  ~FeatureSpool() override;
  FeatureSpool(const FeatureSpool&) = delete;
  FeatureSpool& operator=(const FeatureSpool&) = delete;

  // Adds the next image's features. Errors: the write fails (IoError: a full disk, say).
  Status Append(const FeatureSet& features);
  size_t size() const override;
  StatusOr<TourWindow> Window(size_t begin, size_t end) const override;
  // Bytes written so far.
  uint64_t bytes() const;

 private:
  FeatureSpool(int fd, std::string dir) : fd_(fd), dir_(std::move(dir)) {}
  StatusOr<FeatureSet> Read(size_t image) const;

  const int fd_;
  const std::string dir_;
  // offsets_[i] is where image i starts in the file; offsets_.back() where the next goes.
  std::vector<uint64_t> offsets_{0};
};

}  // namespace sceneloc
