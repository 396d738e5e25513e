#include "server/request_handler.h"

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <new>
#include <optional>

#include "common/map/map_name.h"
#include "common/util/timer.h"
#include "common/util/utc_time.h"
#include "proto/wire.h"
#include "server/jpeg_header.h"

namespace sceneloc {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

// Checks a JPEG's header against the limits, reserves its decoding memory from `budget`
// (waiting up to `deadline`), then decodes and extracts it.
StatusOr<FeatureSet> ExtractJpeg(const std::string& jpeg, const LoadedMap& map,
                                 const RequestLimits& limits, MemoryBudget* budget,
                                 Clock::time_point deadline, v1::Timings* timings) {
  Stopwatch watch;
  SCENELOC_ASSIGN_OR_RETURN(const JpegDimensions dims, ReadJpegDimensions(jpeg));
  if (dims.width > limits.max_image_side || dims.height > limits.max_image_side ||
      static_cast<int64_t>(dims.width) * dims.height > limits.max_image_pixels) {
    return ResourceExhausted("JPEG is " + std::to_string(dims.width) + "x" +
                             std::to_string(dims.height) + "; the server accepts at most " +
                             std::to_string(limits.max_image_side) + " pixels per side and " +
                             std::to_string(limits.max_image_pixels) + " pixels");
  }
  if (const int scans = CountJpegScans(jpeg); scans > limits.max_jpeg_scans) {
    return ResourceExhausted(
        "JPEG has " + std::to_string(scans) + " scans; the server accepts at most " +
        std::to_string(limits.max_jpeg_scans) + " (each scan is a full decoding pass)");
  }
  const int64_t need = EstimateDecodeBytes(dims);
  if (need > budget->capacity()) {
    return ResourceExhausted(
        "decoding this " + std::to_string(dims.width) + "x" + std::to_string(dims.height) +
        (dims.progressive ? " progressive" : "") + " JPEG needs about " + std::to_string(need) +
        " bytes; limits.max_decode_bytes is " + std::to_string(budget->capacity()));
  }
  const MemoryBudget::Lease lease = budget->Acquire(need, deadline);
  if (!lease.held()) {
    return DeadlineExceeded("waited " + std::to_string(static_cast<int>(watch.Milliseconds())) +
                            " ms for " + std::to_string(need) +
                            " bytes of decoding memory (limits.max_decode_bytes " +
                            std::to_string(budget->capacity()) +
                            ", held by other decodes) until the request's deadline");
  }
  // Decoded straight to grey at the smallest size that still covers the map's frame, in
  // either orientation: the decoder applies an EXIF rotation the header does not show.
  const int reduction = std::min(
      DecodeReduction(dims.width, dims.height, map.map.QueryTarget(dims.width, dims.height)),
      DecodeReduction(dims.width, dims.height, map.map.QueryTarget(dims.height, dims.width)));
  SCENELOC_ASSIGN_OR_RETURN(const cv::Mat image,
                            DecodeGray(jpeg, limits.max_image_side, reduction));
  timings->set_decode_ms(watch.Milliseconds());
  watch.Reset();
  const bool turned = (image.cols > image.rows) != (dims.width > dims.height);
  auto features =
      map.extractor->Extract(image, turned ? map.map.QueryTarget(dims.height, dims.width)
                                           : map.map.QueryTarget(dims.width, dims.height));
  timings->set_extract_ms(watch.Milliseconds());
  return features;
}

TokenOwner TokenOwnerOf(const std::string& client, const v1::LocaliseRequest& request,
                        const LoadedMap& map) {
  return {client, request.session(), map.places_key, map.map.num_places(),
          map.sequence->num_speeds()};
}

// The fields of a localise request that are checked before any work: top_k,
// min_confidence, camera_scale and the session's.
Status CheckLocaliseFields(const v1::LocaliseRequest& request, int max_top_k) {
  if (request.top_k() < 0 || request.top_k() > max_top_k) {
    return InvalidArgument("top_k must be in [0, " + std::to_string(max_top_k) +
                           "] (0 = the server's default)");
  }
  if (request.has_min_confidence() &&
      !(request.min_confidence() >= 0.0f && request.min_confidence() <= 1.0f)) {
    return InvalidArgument("min_confidence must be in [0, 1], got " +
                           std::to_string(request.min_confidence()));
  }
  if (request.has_camera_scale())
    SCENELOC_RETURN_IF_ERROR(CheckCameraScale(request.camera_scale()));
  if (!request.session().empty()) SCENELOC_RETURN_IF_ERROR(CheckSessionName(request.session()));
  if (request.session().empty() && (request.reset_session() || !request.session_state().empty())) {
    return InvalidArgument(
        std::string(request.reset_session() ? "reset_session" : "session_state") +
        " needs a session name");
  }
  return Status::Ok();
}

// Reads the session state a request carries (session_token.h), if any and unless it resets
// its session: one that fits `map` and the client goes to *carried; one of another map
// sets *other_map. Errors: a state that cannot be read, or that belongs to someone else.
Status ReadCarriedState(const v1::LocaliseRequest& request, const std::string& client,
                        const LoadedMap& map, std::optional<SequenceState>* carried,
                        bool* other_map) {
  if (request.session().empty() || request.session_state().empty() || request.reset_session()) {
    return Status::Ok();
  }
  SequenceState state;
  SCENELOC_ASSIGN_OR_RETURN(
      const TokenFit fit,
      ParseSessionToken(request.session_state(), TokenOwnerOf(client, request, map), &state));
  *other_map = fit == TokenFit::kOtherMap;
  if (fit == TokenFit::kFits) *carried = std::move(state);
  return Status::Ok();
}

v1::SessionStart ToWireStart(SessionStart start) {
  switch (start) {
    case SessionStart::kContinued:
      return v1::CONTINUED;
    case SessionStart::kNew:
      return v1::NEW;
    case SessionStart::kReset:
      return v1::RESET;
    case SessionStart::kMapReloaded:
      return v1::MAP_RELOADED;
  }
  return v1::NEW;
}

void FillResult(const LocaliseResult& result, const LoadedMap& map, const MatchOptions& match,
                v1::LocaliseReply* reply) {
  for (const RankedLocation& r : result.ranked) {
    v1::RankedLocation* out = reply->add_locations();
    out->set_index(r.index);
    out->set_image_name(r.image_name);
    out->set_likelihood(r.likelihood);
    out->set_inliers(r.inliers);
  }
  reply->set_confidence(result.confidence);
  reply->set_decision(result.decision == Decision::kLocalised ? v1::LOCALISED : v1::UNKNOWN);
  reply->set_confidence_model(ConfidenceModelName(result.confidence_model));
  reply->set_min_confidence(static_cast<float>(match.min_confidence));
  reply->set_tolerance(map.map.options.tolerance);
  reply->mutable_map()->set_name(map.name);
  reply->mutable_map()->set_generation(map.generation);
  reply->mutable_map()->set_checksum(map.checksum);
  reply->set_descriptor_matches(result.descriptor_matches);
  v1::Timings* t = reply->mutable_timings();
  t->set_place_ms(result.timings.place_ms);
  t->set_descriptor_ms(result.timings.descriptor_ms);
  t->set_neighbourhood_ms(result.timings.neighbourhood_ms);
  t->set_likelihood_ms(result.timings.likelihood_ms);
  t->set_holistic_ms(result.timings.holistic_ms);
  t->set_verify_ms(result.timings.verify_ms);
}

}  // namespace

void FillMapInfo(const LoadedMap& map, v1::MapInfo* info) {
  info->mutable_version()->set_name(map.name);
  info->mutable_version()->set_generation(map.generation);
  info->mutable_version()->set_checksum(map.checksum);
  info->set_path(map.path);
  info->set_num_locations(map.map.num_places());
  info->set_num_landmarks(map.map.num_landmarks());
  info->set_memory_bytes(map.map.MemoryBytes());
  info->set_loaded_utc(UtcText(map.loaded_at));
  info->set_confidence_model(
      ConfidenceModelName(SupportedModel(map.map, ConfidenceModel::kCalibrated)));
  info->set_tolerance(map.map.options.tolerance);
  info->set_trained_by(map.map.provenance.tool_version);
  info->set_trained_utc(map.map.provenance.created_utc);
}

RequestHandler::RequestHandler(const ServerOptions& options, MapRegistry* registry,
                               ThreadPool* pool, const ServerStats* stats,
                               std::unique_ptr<FrameKeeper> keeper)
    : options_(options),
      registry_(registry),
      pool_(pool),
      stats_(stats),
      decode_budget_(std::make_unique<MemoryBudget>(options.limits.max_decode_bytes)),
      sessions_(std::make_unique<SessionStore>(options.sessions)),
      keeper_(std::move(keeper)) {}

bool RequestHandler::IsCheap(const v1::Request& request) {
  return request.kind_case() == v1::Request::kStats ||
         request.kind_case() == v1::Request::kListMaps;
}

void RequestHandler::Handle(const v1::Request& request, Clock::time_point received,
                            v1::Reply* reply, const std::string& client) const {
  reply->Clear();
  reply->set_request_id(request.request_id());
  Status status;
  try {
    switch (request.kind_case()) {
      case v1::Request::kLocalise:
        status = HandleLocalise(request.localise(), received, client, reply->mutable_localise());
        break;
      case v1::Request::kListMaps:
        HandleListMaps(reply->mutable_list_maps());
        break;
      case v1::Request::kReloadMap:
        status = HandleReload(request.reload_map(), reply->mutable_reload_map());
        break;
      case v1::Request::kStats:
        HandleStats(reply->mutable_stats());
        break;
      case v1::Request::kKeptFrames:
        status = HandleKeptFrames(request.kept_frames(), reply->mutable_kept_frames());
        break;
      case v1::Request::KIND_NOT_SET:
        status = InvalidArgument("request has no kind set (or one this server does not know)");
        break;
    }
  } catch (const std::bad_alloc&) {
    status = ResourceExhausted("out of memory while handling the request");
  } catch (const std::exception& e) {
    status = Internal(std::string("unexpected exception: ") + e.what());
  } catch (...) {
    status = Internal("unexpected exception");
  }
  if (!status.ok()) {
    reply->clear_kind();
    reply->set_status(ToWireCode(status.code()));
    reply->set_error(status.message());
  }
}

Status RequestHandler::HandleLocalise(const v1::LocaliseRequest& request,
                                      Clock::time_point received, const std::string& client,
                                      v1::LocaliseReply* reply) const {
  v1::Timings timings;
  timings.set_queue_ms(MsSince(received));
  SCENELOC_RETURN_IF_ERROR(CheckLocaliseFields(request, options_.limits.max_top_k));
  // The one snapshot this request uses from here to its reply.
  const std::shared_ptr<const LoadedMap> map = registry_->Get(request.map());
  if (map == nullptr) return NotFound("no map named '" + request.map() + "'");
  // A carried session state is checked before any work is done on the frame.
  std::optional<SequenceState> carried;
  bool other_map = false;
  SCENELOC_RETURN_IF_ERROR(ReadCarriedState(request, client, *map, &carried, &other_map));

  const Clock::time_point deadline =
      received + std::chrono::milliseconds(options_.limits.max_request_ms);
  SCENELOC_ASSIGN_OR_RETURN(const FeatureSet features,
                            QueryFeatures(request, *map, deadline, &timings));

  MatchOptions match = options_.matching;
  match.deadline = deadline;
  if (request.top_k() > 0) match.top_k = request.top_k();
  if (request.has_min_confidence()) match.min_confidence = request.min_confidence();
  if (request.has_camera_scale()) {
    match.camera_log_scale = std::log(request.camera_scale());
    match.camera_known = true;
  }
  StatusOr<LocaliseResult> localised = Localise(features, map->map, match, pool_);
  if (localised.status().code() == StatusCode::kDeadlineExceeded) {
    return DeadlineExceeded(localised.status().message() + "; budget " +
                            std::to_string(options_.limits.max_request_ms) +
                            " ms (max_request_ms) from arrival, queue " +
                            std::to_string(timings.queue_ms()) + " ms, extraction " +
                            std::to_string(timings.extract_ms()) + " ms");
  }
  SCENELOC_ASSIGN_OR_RETURN(LocaliseResult result, std::move(localised));
  match.camera_log_scale = result.camera_log_scale;  // the frame's, unless the request stated one
  match.camera_log_doubt = result.camera_log_doubt;
  if (!request.session().empty()) {
    const SessionSeed seed{request.reset_session(), other_map, carried ? &*carried : nullptr};
    const double camera = UpdateSession(request, client, *map, match, result, seed, reply);
    // The frame's own answer is read with the camera the session read it with (what it has
    // learnt, unless the request states one): the same frame, knowing the robot's camera.
    if (camera != match.camera_log_scale) {
      match.camera_log_scale = camera;
      match.camera_log_doubt = 0;  // measured by the session
      ReadWithCamera(map->map, match, &result);
    }
  }
  FillResult(result, *map, match, reply);
  if (keeper_ != nullptr && reply->has_session()) KeepFrame(request, client, *map, result, *reply);
  reply->set_camera_scale(static_cast<float>(std::exp(match.camera_log_scale)));
  reply->set_num_features(static_cast<uint32_t>(features.size()));
  v1::Timings* t = reply->mutable_timings();
  t->set_queue_ms(timings.queue_ms());
  t->set_decode_ms(timings.decode_ms());
  t->set_extract_ms(timings.extract_ms());
  t->set_total_ms(MsSince(received));
  return Status::Ok();
}

StatusOr<FeatureSet> RequestHandler::QueryFeatures(const v1::LocaliseRequest& request,
                                                   const LoadedMap& map, Clock::time_point deadline,
                                                   v1::Timings* timings) const {
  StatusOr<FeatureSet> features = InvalidArgument("localise request carries no query");
  if (request.query_case() == v1::LocaliseRequest::kJpeg) {
    features =
        ExtractJpeg(request.jpeg(), map, options_.limits, decode_budget_.get(), deadline, timings);
  } else if (request.query_case() == v1::LocaliseRequest::kFeatures) {
    Stopwatch watch;
    features = DecodeFeatureSet(request.features(),
                                {options_.limits.max_keypoints, options_.limits.max_image_side});
    timings->set_extract_ms(watch.Milliseconds());
  }
  if (!features.ok()) return features.status();
  if (Clock::now() > deadline) {
    return DeadlineExceeded("request passed its " + std::to_string(options_.limits.max_request_ms) +
                            " ms budget (max_request_ms) before matching: queue " +
                            std::to_string(timings->queue_ms()) + " ms, decode " +
                            std::to_string(timings->decode_ms()) + " ms, extraction " +
                            std::to_string(timings->extract_ms()) + " ms");
  }
  return features;
}

double RequestHandler::UpdateSession(const v1::LocaliseRequest& request, const std::string& client,
                                     const LoadedMap& map, const MatchOptions& match,
                                     const LocaliseResult& result, const SessionSeed& seed,
                                     v1::LocaliseReply* reply) const {
  FrameEvidence evidence = EvidenceOf(result, map.map, match);
  if (request.has_camera_scale()) evidence.camera_log_scale = match.camera_log_scale;
  SequenceAnswer answer;
  v1::SessionAnswer* out = reply->mutable_session();
  const TokenOwner owner = TokenOwnerOf(client, request, map);
  SequenceState after;  // a copy, serialised outside the store's lock
  const SessionStart start = sessions_->Update(client, map.name, request.session(), map.places_key,
                                               seed, Clock::now(), [&](SequenceState* state) {
                                                 answer = map.sequence->Update(evidence, state);
                                                 after = *state;
                                               });
  out->set_state(SerializeSessionToken(after, owner));
  out->set_name(request.session());
  out->set_location(answer.location);
  out->set_image_name(map.map.PlaceName(answer.location));
  out->set_probability(static_cast<float>(answer.probability));
  out->set_off_map(static_cast<float>(answer.off_map));
  out->set_belief(static_cast<float>(answer.belief));
  out->set_track_support(static_cast<float>(answer.support));
  out->set_decision(answer.decision == Decision::kLocalised ? v1::LOCALISED : v1::UNKNOWN);
  out->set_min_confidence(static_cast<float>(options_.matching.sequence.min_confidence));
  out->set_frames(answer.frames);
  out->set_start(ToWireStart(start));
  out->set_camera_scale(static_cast<float>(std::exp(answer.camera_log_scale)));
  out->set_measured_camera_scale(static_cast<float>(std::exp(answer.measured_camera_log_scale)));
  return answer.camera_log_scale;
}

Status RequestHandler::CheckReload(const v1::ReloadMapRequest& request) {
  if (!IsValidMapName(request.map())) {
    return InvalidArgument("'" + request.map() + "' is not a map name (a plain file stem)");
  }
  return Status::Ok();
}

void RequestHandler::FillReloadReply(uint64_t request_id,
                                     const StatusOr<std::shared_ptr<const LoadedMap>>& loaded,
                                     v1::Reply* reply) {
  reply->Clear();
  reply->set_request_id(request_id);
  if (loaded.ok()) {
    FillMapInfo(**loaded, reply->mutable_reload_map()->mutable_map());
    return;
  }
  reply->set_status(ToWireCode(loaded.status().code()));
  reply->set_error(loaded.status().message());
}

Status RequestHandler::HandleReload(const v1::ReloadMapRequest& request,
                                    v1::ReloadMapReply* reply) const {
  SCENELOC_RETURN_IF_ERROR(CheckReload(request));
  SCENELOC_ASSIGN_OR_RETURN(const auto loaded,
                            registry_->Load(MapFilePath(options_.maps_dir, request.map())));
  FillMapInfo(*loaded, reply->mutable_map());
  return Status::Ok();
}

void RequestHandler::HandleListMaps(v1::ListMapsReply* reply) const {
  for (const auto& map : registry_->List()) FillMapInfo(*map, reply->add_maps());
}

void RequestHandler::HandleStats(v1::StatsReply* reply) const {
  const StatsSnapshot s = stats_->Snapshot();
  reply->set_uptime_s(s.uptime_s);
  reply->set_requests(s.requests);
  reply->set_in_flight(s.in_flight);
  for (const auto& [status, count] : s.replies_by_status) {
    (*reply->mutable_replies_by_status())[status] = count;
  }
  v1::LatencySummary* latency = reply->mutable_localise_latency_ms();
  latency->set_count(s.latency_count);
  latency->set_p50(s.latency_p50_ms);
  latency->set_p90(s.latency_p90_ms);
  latency->set_p99(s.latency_p99_ms);
  const SessionCounts sessions = sessions_->Counts();
  reply->set_sessions(sessions.live);
  reply->set_session_memory_bytes(sessions.memory_bytes);
  reply->set_sessions_evicted(sessions.evicted);
  reply->set_sessions_expired(sessions.expired);
  latency->set_max(s.latency_max_ms);
  reply->set_map_loads(registry_->loads());
  reply->set_map_load_failures(registry_->load_failures());
  reply->set_map_unloads(registry_->unloads());
  reply->set_replies_undelivered(s.replies_undelivered);
  for (const auto& map : registry_->List()) FillMapInfo(*map, reply->add_maps());
}

}  // namespace sceneloc
