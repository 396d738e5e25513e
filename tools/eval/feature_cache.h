// A disk cache of extracted features for the experiment runner: extraction dominates a
// sweep's time, and every variant of a sweep reads the same features. Not a product file
// format (the wire format for feature sets is the server's Protobuf message): a cache
// entry that fails any check is treated as a miss and rebuilt.
#pragma once

#include <string>
#include <vector>

#include "common/features/extractor.h"
#include "common/features/feature_set.h"
#include "common/util/status.h"

namespace sceneloc {

// Extracts the features of the images in `dir` with `options`, or reads them from
// `cache_dir` when an entry made from the same files (paths, sizes, modification times),
// options and frame exists.
// An empty cache_dir disables caching. Without `map_frame` the folder is a tour (every image
// in the tour frame of the first, ExtractFolder); with it, a query folder extracted for a
// map made in that frame (QueryTarget).
StatusOr<std::vector<FeatureSet>> ExtractCached(const std::vector<std::string>& paths,
                                                const ExtractorOptions& options,
                                                const std::string& cache_dir, int threads,
                                                const ExtractionTarget* map_frame = nullptr);

// ExtractCached over every image of `dir`; `names` receives their file names.
StatusOr<std::vector<FeatureSet>> ExtractFolderCached(const std::string& dir,
                                                      const ExtractorOptions& options,
                                                      const std::string& cache_dir, int threads,
                                                      std::vector<std::string>* names,
                                                      const ExtractionTarget* map_frame = nullptr);

}  // namespace sceneloc
