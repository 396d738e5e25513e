// libFuzzer target: one request end to end behind the socket, as a worker runs it:
// Request parse, then RequestHandler::Handle against a real map (trained at start-up from
// the generated tour and loaded through MapRegistry from a file, as the server does):
// map lookup, JPEG checks, decode, extraction, feature-set conversion, the whole engine.
//
// Oracle beyond the sanitizers: no input gets INTERNAL, the status the server keeps for
// its own bugs; every refusal of bad input has its own code. reload_map requests are
// skipped (they touch the maps folder; fuzz_request covers their check).
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "common/map/map_io.h"
#include "fuzz/fuzz_world.h"
#include "proto/sceneloc.pb.h"
#include "server/request_handler.h"

namespace sceneloc {
namespace {

struct Fixture {
  ServerOptions options;
  std::unique_ptr<MapRegistry> registry;
  ServerStats stats;
  std::unique_ptr<RequestHandler> handler;
};

Fixture* MakeFixture() {
  spdlog::set_level(spdlog::level::warn);
  auto world = fuzz::MakeFuzzWorld();
  if (!world.ok()) {
    std::fprintf(stderr, "fuzz_handler: %s\n", world.status().ToString().c_str());
    std::abort();
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("sceneloc-fuzz-handler-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "m.scnl").string();
  auto* f = new Fixture;
  f->options.maps_dir = dir.string();
  f->options.limits.max_request_ms = 2000;  // libFuzzer's -timeout is the backstop
  f->registry = std::make_unique<MapRegistry>(MapRegistry::Options());
  if (!SaveMap(world->map, path).ok() || !f->registry->Load(path).ok()) {
    std::fprintf(stderr, "fuzz_handler: cannot save and load the map in %s\n", path.c_str());
    std::abort();
  }
  std::filesystem::remove_all(dir);  // the registry holds the map in memory
  f->handler = std::make_unique<RequestHandler>(f->options, f->registry.get(), nullptr, &f->stats);
  return f;
}

}  // namespace
}  // namespace sceneloc

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace sceneloc;
  static Fixture* const fixture = MakeFixture();  // leaked on purpose: lives for the process
  v1::Request request;
  if (!request.ParseFromArray(data, static_cast<int>(size))) return 0;
  if (request.kind_case() == v1::Request::kReloadMap) return 0;
  v1::Reply reply;
  fixture->handler->Handle(request, std::chrono::steady_clock::now(), &reply);
  if (reply.status() == v1::INTERNAL) {
    std::fprintf(stderr, "INTERNAL: %s\n", reply.error().c_str());
    std::abort();
  }
  return 0;
}
