// The baselines every accuracy and speed claim is measured against (docs/measurements.md,
// docs/results.md): every feature of every tour image in one FLANN kd-tree index; each
// query feature votes for the tour image of its nearest neighbour when it passes Lowe's
// ratio test (0.8); tour images are ranked by votes. The stronger variant a user would
// script next re-ranks the rerank_top most-voted images by the number of
// fundamental-matrix RANSAC inliers among the ratio-test matches between the query and
// that image.
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
  // Re-rank this many most-voted images by RANSAC inliers (0 = votes only).
  int rerank_top = 10;
  // RANSAC inlier distance, pixels of the frame the features were extracted in.
  double ransac_threshold_px = 3.0;
};

struct BaselineResult {
  std::vector<int> votes;  // per tour image
  int best = -1;           // tour image with most votes (lowest index on ties); -1 if none
  float confidence = 0;    // the vote share of the best: v1 / (v1 + v2), as ours once was
  // The re-ranked variant (when rerank_top > 0): the image with most inliers among the
  // rerank_top most voted (votes break ties), its inliers, and their share i1 / (i1 + i2).
  int reranked_best = -1;
  int reranked_inliers = 0;
  float reranked_confidence = 0;
  double rerank_ms = 0;  // time the re-ranking took (on top of the vote)
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
