// The landmarks one query is scored against: every landmark of the map (the paper), or the
// landmarks of the candidate locations the coarse stage picked (place_search.h). The fine
// stage numbers its landmarks 0 .. size() - 1 in ascending map order ("scope positions"):
// S_D's matches, S_N's lookups and the per-landmark scores are all by position, so a
// query's work and memory grow with its scope, not with the map.
//
// Thread-safe for reading once made (any number of pool threads may call Position); the
// scope itself belongs to one query.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "common/map/map.h"

namespace sceneloc {

class LandmarkScope {
 public:
  // Every landmark and location of `map`.
  static LandmarkScope Whole(const Map& map);
  // The landmarks of `locations` (G_l, ascending tour locations, each within the map).
  static LandmarkScope Of(const Map& map, std::vector<int> locations);

  LandmarkScope(LandmarkScope&&) noexcept;
  LandmarkScope& operator=(LandmarkScope&&) noexcept;
  ~LandmarkScope();

  bool whole() const { return whole_; }
  size_t size() const { return size_; }
  // The map's landmark at scope position i. REQUIRES: i < size().
  uint32_t landmark(size_t i) const { return whole_ ? static_cast<uint32_t>(i) : landmarks_[i]; }
  // The scope position of map landmark g, or -1 when g is outside the scope.
  int32_t Position(uint32_t g) const { return whole_ ? static_cast<int32_t>(g) : (*position_)[g]; }
  // The locations whose landmarks it holds, ascending (every location when whole()).
  const std::vector<int>& locations() const { return locations_; }

 private:
  LandmarkScope() = default;

  bool whole_ = true;
  size_t size_ = 0;
  std::vector<uint32_t> landmarks_;  // ascending; empty when whole
  std::vector<int> locations_;
  // landmark -> position (-1 outside), as long as the map has landmarks: borrowed from a
  // pool of such arrays and handed back, every entry -1 again, when the scope ends, so a
  // query pays for the entries it sets and not for the map's size.
  std::unique_ptr<std::vector<int32_t>> position_;
};

}  // namespace sceneloc
