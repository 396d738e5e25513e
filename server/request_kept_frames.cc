// RequestHandler's part for the frame keeper (frame_keeper.h): telling it how each session
// frame was answered, and the kept_frames requests.
#include <algorithm>

#include "server/request_handler.h"

namespace sceneloc {
namespace {

void FillRun(const KeptRun& run, v1::KeptRun* out) {
  out->set_map(run.map);
  out->set_run(run.run);
  out->set_session(run.session);
  out->set_client(run.client);
  out->set_started_utc(run.started_utc);
  out->set_last_utc(run.last_utc);
  out->set_frames(static_cast<uint32_t>(run.frames));
  out->set_bytes(static_cast<uint64_t>(run.bytes));
  out->set_map_checksum(run.map_checksum);
  out->set_anchor_place(run.anchor_place);
  out->set_anchor_name(run.anchor_name);
  out->set_anchor_probability(static_cast<float>(run.anchor_probability));
  out->set_anchor_utc(run.anchor_utc);
}

}  // namespace

void RequestHandler::KeepFrame(const v1::LocaliseRequest& request, const std::string& client,
                               const LoadedMap& map, const LocaliseResult& result,
                               const v1::LocaliseReply& reply) const {
  SessionFrame frame;
  frame.client = client;
  frame.map = map.name;
  frame.session = request.session();
  frame.reset = request.reset_session() || reply.session().start() != v1::CONTINUED;
  frame.map_checksum = map.checksum;
  if (request.query_case() == v1::LocaliseRequest::kJpeg) frame.jpeg = request.jpeg();
  if (!result.ranked.empty()) frame.frame_place = result.ranked.front().index;
  frame.frame_confidence = result.confidence;
  const v1::SessionAnswer& session = reply.session();
  frame.session_place = session.location();
  frame.session_place_name = session.image_name();
  frame.session_probability = session.probability();
  frame.off_map = session.off_map();
  frame.localised = session.decision() == v1::LOCALISED;
  keeper_->Observe(frame, std::chrono::system_clock::now());
}

Status RequestHandler::HandleKeptFrames(const v1::KeptFramesRequest& request,
                                        v1::KeptFramesReply* reply) const {
  if (keeper_ == nullptr) {
    return FailedPrecondition(
        "this server keeps no frames: start it with keep_frames.dir set (--keep-frames DIR)");
  }
  switch (request.action()) {
    case v1::KeptFramesRequest::LIST: {
      SCENELOC_ASSIGN_OR_RETURN(const std::vector<KeptRun> runs, keeper_->List(request.map()));
      for (const KeptRun& run : runs) FillRun(run, reply->add_runs());
      break;
    }
    case v1::KeptFramesRequest::FETCH: {
      // A page stays well inside what a client or broker accepts in one message.
      const int64_t page_bytes = std::min<int64_t>(4 << 20, options_.limits.max_message_bytes);
      SCENELOC_ASSIGN_OR_RETURN(
          KeptPage page,
          keeper_->Fetch(request.map(), request.run(),
                         static_cast<int>(std::min<uint32_t>(request.first_frame(), 1u << 30)),
                         page_bytes));
      FillRun(page.run, reply->add_runs());
      for (KeptFrame& f : page.frames) {
        v1::KeptFrame* out = reply->add_frames();
        out->set_index(static_cast<uint32_t>(f.index));
        out->set_file(f.file);
        out->set_utc(f.utc);
        out->set_jpeg(std::move(f.jpeg));
      }
      reply->set_next_frame(static_cast<uint32_t>(page.next_frame));
      reply->set_record(std::move(page.record));
      break;
    }
    case v1::KeptFramesRequest::DELETE: {
      SCENELOC_ASSIGN_OR_RETURN(const KeptRun gone, keeper_->Delete(request.map(), request.run()));
      FillRun(gone, reply->add_runs());
      break;
    }
    default:
      return InvalidArgument("kept_frames action " + std::to_string(request.action()) +
                             " is not one this server knows");
  }
  const KeepFramesCounts counts = keeper_->Counts();
  reply->set_bytes_used(static_cast<uint64_t>(counts.bytes_used));
  reply->set_quota_bytes(static_cast<uint64_t>(counts.quota_bytes));
  return Status::Ok();
}

}  // namespace sceneloc
