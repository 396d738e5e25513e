// One parsed request in, its reply out: the work behind the socket, without ZeroMQ (so
// it is tested directly). Every failure a client can cause becomes an error reply with
// its status and a readable message; no input makes Handle throw or crash.
//
//   localise:  map snapshot (NOT_FOUND) -> JPEG header check -> decode -> extract with the
//              map's settings   |  or: decode + check the feature set
//              -> Localise (common/matching/localiser.h) -> ranked locations, timings
//   list_maps, stats:  read the registry and the counters
//   kept_frames:       list, fetch or delete the frames the keeper kept (frame_keeper.h);
//                      a localise of a session tells the keeper how its frame was answered
//   reload_map:        MapRegistry::Load of <maps_dir>/<name>.scnl (the server runs it on
//                      its map loader thread instead: CheckReload + FillReloadReply)
//
// Thread-safe: Handle may run on any number of threads at once.
#pragma once

#include <chrono>
#include <memory>

#include "common/util/thread_pool.h"
#include "proto/sceneloc.pb.h"
#include "server/frame_keeper.h"
#include "server/map_registry.h"
#include "server/memory_budget.h"
#include "server/server_options.h"
#include "server/server_stats.h"
#include "server/session_store.h"
#include "server/session_token.h"

namespace sceneloc {

class RequestHandler {
 public:
  // The pointees must outlive the handler. `pool` (may be null) splits one request's
  // scoring when it has idle threads. `keeper` (may be null: no frame is kept) is told of
  // every answered session frame and serves kept_frames requests.
  RequestHandler(const ServerOptions& options, MapRegistry* registry, ThreadPool* pool,
                 const ServerStats* stats, std::unique_ptr<FrameKeeper> keeper = nullptr);

  // Fills `reply` (cleared first) for `request`, which arrived at `received` from `client`
  // (its key name with auth.enabled, else empty; sessions are kept per client).
  void Handle(const v1::Request& request, std::chrono::steady_clock::time_point received,
              v1::Reply* reply, const std::string& client = {}) const;

  // True for requests cheap enough to answer on the I/O thread (stats, list_maps), so a
  // health check is answered even when every worker is busy.
  static bool IsCheap(const v1::Request& request);

  // The live sessions of every map (thread-safe).
  SessionCounts sessions() const { return sessions_->Counts(); }
  // The frame keeper; null when keep_frames.dir is not set.
  const FrameKeeper* keeper() const { return keeper_.get(); }

  // InvalidArgument unless the request names a map by a plain file stem (one that cannot
  // reach outside the maps directory).
  static Status CheckReload(const v1::ReloadMapRequest& request);
  // Fills `reply` (cleared first) to request `request_id` from a finished reload.
  static void FillReloadReply(uint64_t request_id,
                              const StatusOr<std::shared_ptr<const LoadedMap>>& loaded,
                              v1::Reply* reply);

 private:
  Status HandleLocalise(const v1::LocaliseRequest& request,
                        std::chrono::steady_clock::time_point received, const std::string& client,
                        v1::LocaliseReply* reply) const;
  // The request's query as features: its JPEG decoded and extracted, or its feature set
  // decoded, timed into `timings`. DeadlineExceeded when that ends past `deadline`.
  StatusOr<FeatureSet> QueryFeatures(const v1::LocaliseRequest& request, const LoadedMap& map,
                                     std::chrono::steady_clock::time_point deadline,
                                     v1::Timings* timings) const;
  // Adds the frame to its session and the session's answer to `reply`; returns the camera
  // log scale the session read the frame with.
  double UpdateSession(const v1::LocaliseRequest& request, const std::string& client,
                       const LoadedMap& map, const MatchOptions& match,
                       const LocaliseResult& result, const SessionSeed& seed,
                       v1::LocaliseReply* reply) const;
  // Tells the keeper how a session's JPEG frame was answered.
  void KeepFrame(const v1::LocaliseRequest& request, const std::string& client,
                 const LoadedMap& map, const LocaliseResult& result,
                 const v1::LocaliseReply& reply) const;
  Status HandleKeptFrames(const v1::KeptFramesRequest& request, v1::KeptFramesReply* reply) const;
  Status HandleReload(const v1::ReloadMapRequest& request, v1::ReloadMapReply* reply) const;
  void HandleListMaps(v1::ListMapsReply* reply) const;
  void HandleStats(v1::StatsReply* reply) const;

  const ServerOptions options_;
  MapRegistry* const registry_;
  ThreadPool* const pool_;
  const ServerStats* const stats_;
  // Memory of the JPEG decodes running at once (limits.max_decode_bytes).
  const std::unique_ptr<MemoryBudget> decode_budget_;
  // The sessions of every map (thread-safe).
  const std::unique_ptr<SessionStore> sessions_;
  const std::unique_ptr<FrameKeeper> keeper_;  // thread-safe; may be null
};

// Writes what identifies and describes a loaded map.
void FillMapInfo(const LoadedMap& map, v1::MapInfo* info);

}  // namespace sceneloc
