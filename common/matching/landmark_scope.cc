#include "common/matching/landmark_scope.h"

#include <algorithm>
#include <numeric>

#include "common/util/mutex.h"

namespace sceneloc {
namespace {

// Position arrays not in use, every entry -1. Bounded by the most scopes alive at once
// (about one per thread); each as long as the largest map it served.
class PositionPool {
 public:
  std::unique_ptr<std::vector<int32_t>> Take(size_t size) EXCLUDES(mutex_) {
    std::unique_ptr<std::vector<int32_t>> out;
    {
      MutexLock lock(&mutex_);
      if (!free_.empty()) {
        out = std::move(free_.back());
        free_.pop_back();
      }
    }
    if (!out) out = std::make_unique<std::vector<int32_t>>();
    if (out->size() < size) out->resize(size, -1);
    return out;
  }
  void Give(std::unique_ptr<std::vector<int32_t>> array) EXCLUDES(mutex_) {
    MutexLock lock(&mutex_);
    free_.push_back(std::move(array));
  }

 private:
  Mutex mutex_;
  std::vector<std::unique_ptr<std::vector<int32_t>>> free_ GUARDED_BY(mutex_);
};

PositionPool& Pool() {
  static PositionPool* pool = new PositionPool();  // never destroyed: no exit-time order
  return *pool;
}

}  // namespace

LandmarkScope LandmarkScope::Whole(const Map& map) {
  LandmarkScope scope;
  scope.size_ = static_cast<size_t>(map.num_landmarks());
  scope.locations_.resize(static_cast<size_t>(map.num_images()));
  std::iota(scope.locations_.begin(), scope.locations_.end(), 0);
  return scope;
}

LandmarkScope LandmarkScope::Of(const Map& map, std::vector<int> locations) {
  LandmarkScope scope;
  scope.whole_ = false;
  scope.locations_ = std::move(locations);
  for (int l : scope.locations_) {
    scope.landmarks_.insert(scope.landmarks_.end(),
                            map.image_landmarks.begin() + map.image_offsets[l],
                            map.image_landmarks.begin() + map.image_offsets[l + 1]);
  }
  std::sort(scope.landmarks_.begin(), scope.landmarks_.end());
  scope.landmarks_.erase(std::unique(scope.landmarks_.begin(), scope.landmarks_.end()),
                         scope.landmarks_.end());
  scope.size_ = scope.landmarks_.size();
  scope.position_ = Pool().Take(static_cast<size_t>(map.num_landmarks()));
  for (size_t i = 0; i < scope.landmarks_.size(); ++i) {
    (*scope.position_)[scope.landmarks_[i]] = static_cast<int32_t>(i);
  }
  return scope;
}

LandmarkScope::LandmarkScope(LandmarkScope&&) noexcept = default;
LandmarkScope& LandmarkScope::operator=(LandmarkScope&& other) noexcept {
  if (this != &other) {
    this->~LandmarkScope();
    new (this) LandmarkScope(std::move(other));
  }
  return *this;
}

LandmarkScope::~LandmarkScope() {
  if (!position_) return;
  for (uint32_t g : landmarks_) (*position_)[g] = -1;
  Pool().Give(std::move(position_));
}

}  // namespace sceneloc
