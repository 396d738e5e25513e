// The server's maps: name -> the loaded map snapshot now serving under that name.
//
// A request takes its snapshot once (Get) and uses only it, so a reload or a removal
// never changes a map under a running request: the old snapshot lives until the last
// request holding it finishes (docs/server.md "Hot reload"; LevelDB pins its version per read the
// same way).
//
// Loading reads, checksums and validates the whole file (LoadMap) and then runs a
// self-test query built from the map's own landmarks, all without holding the registry
// lock; only the final pointer swap is under it. A failed load changes nothing.
//
// Thread-safe: every method may be called from any thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/features/extractor.h"
#include "common/map/map.h"
#include "common/map/map_io.h"
#include "common/map/map_name.h"
#include "common/matching/localiser.h"
#include "common/matching/self_test.h"
#include "common/matching/sequence_filter.h"
#include "common/util/mutex.h"
#include "common/util/status.h"
#include "common/util/thread_annotations.h"

namespace sceneloc {

// One immutable map snapshot and what identifies it.
struct LoadedMap {
  std::string name;         // the file stem
  std::string path;         // the file it was loaded from
  uint64_t generation = 0;  // 1 on the first load of this name, +1 on each later load
  uint32_t checksum = 0;    // MapFileInfo::checksum: the content's CRC-32
  uint32_t places_key = 0;  // map.PlacesKey(): what sessions are kept against
  std::chrono::system_clock::time_point loaded_at;
  Map map;  // Validate()d and Finalize()d
  // Extracts query features exactly as the map's tour was extracted (its own settings).
  std::unique_ptr<FeatureExtractor> extractor;
  // The filter of this map's sessions (the registry's matching settings, sequence:).
  std::unique_ptr<const SequenceFilter> sequence;
};

class MapRegistry {
 public:
  struct Options {
    // Settings of the self-test query run on every map before it is swapped in.
    MatchOptions self_test;
    // Tour locations probed by the self-test (spread over the tour), 0 = none.
    int self_test_locations = 3;
    // Limits on the map files read (LoadMap).
    MapLoadOptions load;
  };

  explicit MapRegistry(const Options& options);

  // The snapshot serving `name`, or null when there is none.
  std::shared_ptr<const LoadedMap> Get(const std::string& name) const EXCLUDES(mutex_);
  // Every snapshot, by name.
  std::vector<std::shared_ptr<const LoadedMap>> List() const EXCLUDES(mutex_);

  // Loads `path` and serves it as its file stem, replacing any map of that name. Errors
  // (the old map, if any, keeps serving): those of LoadMap, FailedPrecondition when the
  // self-test fails, InvalidArgument for a name that is not a plain file stem.
  // Loads of one registry run one at a time, so generations follow the swaps' order.
  StatusOr<std::shared_ptr<const LoadedMap>> Load(const std::string& path)
      EXCLUDES(load_mutex_, mutex_);

  // Stops serving `name`; requests holding its snapshot finish on it. False when absent.
  // Waits for a Load() in progress, so a load and a removal never interleave.
  bool Remove(const std::string& name) EXCLUDES(load_mutex_, mutex_);

  // Loads every *.scnl file in `dir` (in name order). Each failure is appended to
  // *failures (which may be null) and does not stop the others. The names of the other
  // entries (not hidden, not a map being written by SaveMap) go to *ignored when it is not
  // null, so an operator who named a map `lab.map` is told. Error only when `dir` cannot
  // be listed.
  Status LoadDirectory(const std::string& dir, std::vector<Status>* failures,
                       std::vector<std::string>* ignored = nullptr) EXCLUDES(load_mutex_, mutex_);

  uint64_t loads() const EXCLUDES(mutex_);          // successful loads so far
  uint64_t load_failures() const EXCLUDES(mutex_);  // failed loads so far
  uint64_t unloads() const EXCLUDES(mutex_);        // successful Remove() calls so far

 private:
  Status SelfTest(const Map& map) const;
  // Counts a failed load and returns `status`.
  Status CountFailure(Status status) EXCLUDES(mutex_);

  // Constant after construction.
  const Options options_;

  // Serialises Load() and Remove() calls (a load and a removal never interleave); never
  // held by Get(). Taken before mutex_.
  Mutex load_mutex_ ACQUIRED_BEFORE(mutex_);

  mutable Mutex mutex_;
  // Guarded by mutex_.
  std::map<std::string, std::shared_ptr<const LoadedMap>> maps_ GUARDED_BY(mutex_);
  // Kept after Remove, so numbers only grow.
  std::map<std::string, uint64_t> generations_ GUARDED_BY(mutex_);
  uint64_t loads_ GUARDED_BY(mutex_) = 0;
  uint64_t load_failures_ GUARDED_BY(mutex_) = 0;
  uint64_t unloads_ GUARDED_BY(mutex_) = 0;
};

}  // namespace sceneloc
