#include "client/frames_command.h"

#include <cstdio>
#include <filesystem>
#include <system_error>

#include "common/util/file_io.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

int Fail(const Status& status, int code) {
  std::fprintf(stderr, "sceneloc: %s\n", status.message().c_str());
  return code;
}

void PrintRun(const v1::KeptRun& r) {
  std::printf("%s\t%s\t%u frames\t%.1f MB\tsession %s\t%s .. %s\t", r.map().c_str(),
              r.run().c_str(), r.frames(), static_cast<double>(r.bytes()) / 1e6,
              r.session().c_str(), r.started_utc().c_str(), r.last_utc().c_str());
  if (r.anchor_place() >= 0) {
    std::printf("last LOCALISED at %d %s (%.2f) %s\n", r.anchor_place(), r.anchor_name().c_str(),
                r.anchor_probability(), r.anchor_utc().c_str());
  } else {
    std::printf("never LOCALISED before\n");
  }
}

void PrintUsage(const v1::KeptFramesReply& reply) {
  std::printf("kept: %.1f MB of %.1f MB\n", static_cast<double>(reply.bytes_used()) / 1e6,
              static_cast<double>(reply.quota_bytes()) / 1e6);
}

// Fetches one run page by page into out/<run>/ and out/<run>.yaml.
int FetchRun(Client* client, const std::string& map, const std::string& run,
             const std::string& out) {
  v1::KeptFramesRequest request;
  request.set_action(v1::KeptFramesRequest::FETCH);
  request.set_map(map);
  request.set_run(run);
  const fs::path dir = fs::path(out) / run;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Fail(IoError("cannot make '" + dir.string() + "': " + ec.message()), 2);
  std::string record;  // the run's record file, as the server keeps it
  size_t frames = 0;
  for (;;) {
    auto page = client->KeptFrames(request);
    if (!page.ok()) return Fail(page.status(), 1);
    for (const v1::KeptFrame& f : page->frames()) {
      if (const Status written = WriteFileAtomically((dir / f.file()).string(), f.jpeg());
          !written.ok()) {
        return Fail(written, 2);
      }
    }
    frames += static_cast<size_t>(page->frames_size());
    record = page->record();
    const uint32_t total = page->runs_size() > 0 ? page->runs(0).frames() : 0;
    if (page->frames_size() == 0 || page->next_frame() >= total) break;
    request.set_first_frame(page->next_frame());
  }
  const std::string path = (fs::path(out) / (run + ".yaml")).string();
  if (const Status written = WriteFileAtomically(path, record); !written.ok()) {
    return Fail(written, 2);
  }
  std::printf("%s: %zu frames -> %s (a walk for sceneloc-train --extend)\n", run.c_str(), frames,
              dir.string().c_str());
  return 0;
}

}  // namespace

int RunFrames(Client* client, const FramesArgs& args) {
  v1::KeptFramesRequest request;
  request.set_map(args.map);
  if (args.action == "list") {
    request.set_action(v1::KeptFramesRequest::LIST);
    auto reply = client->KeptFrames(request);
    if (!reply.ok()) return Fail(reply.status(), 1);
    for (const v1::KeptRun& run : reply->runs()) PrintRun(run);
    PrintUsage(*reply);
    return 0;
  }
  if (args.map.empty()) return Fail(InvalidArgument(args.action + " needs --map"), 2);
  if (args.action == "delete") {
    if (args.run.empty()) return Fail(InvalidArgument("delete needs --run"), 2);
    request.set_action(v1::KeptFramesRequest::DELETE);
    request.set_run(args.run);
    auto reply = client->KeptFrames(request);
    if (!reply.ok()) return Fail(reply.status(), 1);
    std::printf("deleted %s of map %s\n", args.run.c_str(), args.map.c_str());
    PrintUsage(*reply);
    return 0;
  }
  if (args.action != "fetch") {
    return Fail(InvalidArgument("unknown action '" + args.action + "' (list, fetch, delete)"), 2);
  }
  if (args.out.empty()) return Fail(InvalidArgument("fetch needs --out DIR"), 2);
  std::vector<std::string> runs;
  if (!args.run.empty()) {
    runs.push_back(args.run);
  } else {
    request.set_action(v1::KeptFramesRequest::LIST);
    auto listed = client->KeptFrames(request);
    if (!listed.ok()) return Fail(listed.status(), 1);
    for (const v1::KeptRun& run : listed->runs()) runs.push_back(run.run());
  }
  for (const std::string& run : runs) {
    if (const int status = FetchRun(client, args.map, run, args.out); status != 0) return status;
  }
  return 0;
}

}  // namespace sceneloc
