// A reliability diagram as a PNG, drawn with OpenCV (no plotting stack needed): per
// confidence bin, the accuracy of its answers (bars) against the diagonal a perfectly
// calibrated confidence follows, with the bin counts, ECE and PR-AUC in the caption.
#pragma once

#include <string>
#include <vector>

#include "common/util/status.h"
#include "tools/eval/confidence_metrics.h"

namespace sceneloc {

struct ReliabilityPanel {
  std::string title;  // e.g. "gp_day: sceneloc"
  ConfidenceMetrics metrics;
};

// One panel per entry, side by side, written to `path`. Errors: cannot write.
Status WriteReliabilityDiagram(const std::vector<ReliabilityPanel>& panels,
                               const std::string& path);

}  // namespace sceneloc
