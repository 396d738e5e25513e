// A request on the I/O thread: read, checked (frames, size, parse, protocol, permission),
// then answered inline, handed to the loader, queued for the workers or refused.
#include <spdlog/spdlog.h>

#include "server/zmq_server.h"

namespace sceneloc {

void ZmqServer::ReadRequest(bool draining) {
  const Clock::time_point received = Clock::now();
  Incoming in = ReceiveFrames();
  if (in.frames == 0) return;
  stats_.RecordRequest();
  const uint64_t peeked_id = PeekRequestId(in.payload);
  auto refuse = [&](v1::StatusCode code, const std::string& error) {
    const v1::Reply reply = ErrorReply(peeked_id, code, error);
    Record("request", nullptr, reply, received);
    ToClient(in.identity, in.delimited, reply);
  };
  if (in.frames > kMaxFrames || (in.frames == 3 && !in.delimited) || in.frames < 2) {
    return refuse(v1::INVALID_ARGUMENT, "a request is [empty frame][Request] (got " +
                                            std::to_string(in.frames - 1) +
                                            " frames after the identity)");
  }
  if (in.bytes > static_cast<size_t>(options_.limits.max_message_bytes)) {
    return refuse(v1::RESOURCE_EXHAUSTED,
                  "request is " + std::to_string(in.bytes) + " bytes; at most " +
                      std::to_string(options_.limits.max_message_bytes) + " are accepted");
  }
  auto job = std::make_unique<Job>();
  job->bytes = in.bytes;
  job->parsed = in.payload.size() <= kInlineParseBytes;
  if (job->parsed &&
      !job->request.ParseFromArray(in.payload.data(), static_cast<int>(in.payload.size()))) {
    return refuse(v1::INVALID_ARGUMENT, "request is not a valid sceneloc.v1.Request");
  }
  if (job->parsed) {
    if (const auto refusal = ProtocolRefusal(job->request, !options_.connect.empty())) {
      Record(KindName(job->request), &job->request, *refusal, received);
      return ToClient(in.identity, in.delimited, *refusal);
    }
  }
  if (job->parsed && job->request.kind_case() == v1::Request::kReloadMap &&
      !options_.connect.empty()) {
    // Behind a broker a request reaches one worker of many, and any client that reaches
    // the broker could send it: a reload there would put the fleet out of step.
    return refuse(v1::FAILED_PRECONDITION,
                  "reload_map is not taken through a broker (it would reach one worker of "
                  "many): put the map file in every worker's maps folder (each reloads it on "
                  "its own) or send each worker SIGHUP");
  }
  if (job->parsed && job->request.kind_case() == v1::Request::kKeptFrames &&
      !options_.connect.empty()) {
    return refuse(v1::FAILED_PRECONDITION,
                  "kept_frames is not taken through a broker (each worker keeps the frames it "
                  "answered): read the worker's keep_frames.dir, which sceneloc-train --extend "
                  "takes as it is");
  }
  if (zap_ != nullptr) {
    job->client = UserOf(in.payload);
    const Status allowed = CheckPermission(job->client, job->parsed ? &job->request : nullptr);
    if (!allowed.ok()) return refuse(v1::PERMISSION_DENIED, allowed.message());
  }
  if (draining) return refuse(v1::UNAVAILABLE, "server is shutting down");
  if (!job->parsed) job->raw = std::move(in.payload);
  job->identity = std::move(in.identity);
  job->delimited = in.delimited;
  job->received = received;
  Dispatch(std::move(job));
}

std::string ZmqServer::UserOf(zmq::message_t& payload) {
  try {
    return payload.gets("User-Id");
  } catch (const zmq::error_t&) {
    return {};
  }
}

Status ZmqServer::CheckPermission(const std::string& user, const v1::Request* request) const {
  const ZapHandler::Role role = zap_->RoleOf(user);
  if (role == ZapHandler::Role::kUnknown) {
    return PermissionDenied("key '" + user + "' is no longer in " + options_.auth.clients);
  }
  if (request != nullptr && role != ZapHandler::Role::kAdmin &&
      (request->kind_case() == v1::Request::kReloadMap ||
       request->kind_case() == v1::Request::kKeptFrames)) {
    return PermissionDenied(std::string(KindName(*request)) + " needs an admin key; '" + user +
                            "' is not marked admin in " + options_.auth.clients);
  }
  return Status::Ok();
}

void ZmqServer::Dispatch(std::unique_ptr<Job> job) {
  if (job->parsed && job->request.kind_case() == v1::Request::kReloadMap) {
    return DispatchReload(std::move(job));
  }
  if (job->parsed && RequestHandler::IsCheap(job->request)) {
    v1::Reply reply;
    handler_.Handle(job->request, job->received, &reply);
    Record(KindName(job->request), &job->request, reply, job->received);
    ToClient(job->identity, job->delimited, reply);
    return;
  }
  const std::string connection = ConnectionKey(job->identity);
  const size_t bytes = job->bytes;
  const bool large = !job->parsed;  // parsed on a worker: more than kInlineParseBytes
  Refusal refusal = AdmissionRefusal(connection, job->client, bytes, large);
  if (refusal.why.empty()) refusal = WaitRefusal(large);
  if (refusal.why.empty()) {
    const std::string client = job->client;
    if (queue_.TryPush(job, large)) {
      ++outstanding_;
      Track(connection, client);
      queued_bytes_ += static_cast<int64_t>(bytes);
      return;
    }
    refusal = {std::to_string(options_.queue_capacity) +
                   " requests are already waiting (server.queue_capacity)",
               QueuedWorkMs(large)};
  }
  const uint64_t id = job->parsed ? job->request.request_id() : PeekRequestId(job->raw);
  const v1::Reply reply = OverloadedReply(id, refusal);
  Record(job->parsed ? KindName(job->request) : "localise", job->parsed ? &job->request : nullptr,
         reply, job->received);
  ToClient(job->identity, job->delimited, reply);
}

void ZmqServer::DispatchReload(std::unique_ptr<Job> job) {
  const uint64_t id = job->request.request_id();
  auto refuse = [&](v1::StatusCode code, const std::string& error) {
    const v1::Reply reply = ErrorReply(id, code, error);
    Record("reload_map", &job->request, reply, job->received);
    ToClient(job->identity, job->delimited, reply);
  };
  const Status checked = RequestHandler::CheckReload(job->request.reload_map());
  if (!checked.ok()) return refuse(ToWireCode(checked.code()), checked.message());
  const std::string map = job->request.reload_map().map();
  std::shared_ptr<Job> shared = std::move(job);
  const MapLoader::Queued queued =
      loader_->Reload(map, [this, shared](const MapLoader::LoadResult* loaded) {
        // On the loader thread: the only user of loader_push_.
        v1::Reply reply;
        if (loaded != nullptr) {
          RequestHandler::FillReloadReply(shared->request.request_id(), *loaded, &reply);
        } else {
          reply = ErrorReply(shared->request.request_id(), v1::UNAVAILABLE,
                             "server shut down before the reload was started");
        }
        Record("reload_map", &shared->request, reply, shared->received);
        try {
          SendReply(loader_push_, shared->identity, shared->delimited, reply);
        } catch (const zmq::error_t& e) {
          spdlog::error("map loader: cannot pass a reply to the I/O thread: {}", e.what());
        }
      });
  if (queued == MapLoader::Queued::kQueued) {
    ++outstanding_;
    Track(ConnectionKey(shared->identity), shared->client);
    return;
  }
  job = std::make_unique<Job>(std::move(*shared));
  if (queued == MapLoader::Queued::kOverloaded) {
    // A map load takes about a second (a 22 MB map: 0.3-1 s); the hint is one load.
    const v1::Reply reply = OverloadedReply(
        id,
        {std::to_string(kMaxWaitingReloads) + " reload_map requests are already waiting", 1000});
    Record("reload_map", &job->request, reply, job->received);
    return ToClient(job->identity, job->delimited, reply);
  }
  refuse(v1::UNAVAILABLE, "server is shutting down");
}

}  // namespace sceneloc
