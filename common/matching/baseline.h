// The baseline every accuracy and speed claim is measured against (DESIGN.md): every
// feature of every tour image in one FLANN kd-tree index; each query feature votes for
// the tour image of its nearest neighbour when it passes Lowe's ratio test (0.8); tour
// images are ranked by votes.
#pragma once

#include <memory>
#include <vector>

#include "common/features/feature_set.h"
#include "common/util/status.h"

namespace sceneloc {

struct BaselineOptions {
  double ratio = 0.8;  // Lowe's ratio on distances (not squared)
  int trees = 4;       // FLANN randomised kd-trees
  int checks = 64;     // FLANN leaves checked per query
};

struct BaselineResult {
  std::vector<int> votes;  // per tour image
  int best = -1;           // tour image with most votes (lowest index on ties); -1 if none
  float confidence = 0;    // v1 / (v1 + v2), the same form as ours
};

// Not thread-safe: FLANN's search is not documented as safe for concurrent calls, so call
// Localise from one thread at a time (sceneloc-eval does).
class VotingBaseline {
 public:
  virtual ~VotingBaseline() = default;
  static StatusOr<std::unique_ptr<VotingBaseline>> Build(const std::vector<FeatureSet>& tour,
                                                         const BaselineOptions& options);
  virtual BaselineResult Localise(const FeatureSet& query) = 0;
};

}  // namespace sceneloc
