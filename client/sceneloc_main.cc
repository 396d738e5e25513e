// sceneloc: the command-line client.
//   sceneloc localise --server EP --map NAME IMAGE...           one answer line per image
//   sceneloc localise ... --session NAME IMAGE...  the images in order as one robot's session
//   sceneloc localise --server EP --map NAME --features FILE...  feature sets instead
//   sceneloc extract IMAGE --out FILE [--config train.yaml] [--image-scale S] [--float32]
//   sceneloc maps --server EP          sceneloc reload --server EP --map NAME
//   sceneloc stats --server EP
//   sceneloc bench --server EP --map NAME --clients N --duration S [--features] [--sessions]
//                  [--json OUT] DIR
//   sceneloc keygen NAME [--dir DIR] [--force]   a CURVE key pair: NAME.key and NAME.pub
//   sceneloc frames list|fetch|delete --server EP [--map NAME] [--run RUN] [--out DIR]
//                  the frames the server kept where its maps failed (client/frames_command.h)
// Every command that talks to a server takes --key FILE --server-key FILE when the server
// runs with auth.enabled (docs/security.md).
// Exit status: 0 when every request was answered OK, 1 when any got an error reply or
// none at all, 2 for bad arguments or unreadable files.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "client/bench_command.h"
#include "client/client.h"
#include "client/client_extractor.h"
#include "client/frames_command.h"
#include "common/config/config.h"
#include "common/features/extractor.h"
#include "common/keys/keys.h"
#include "common/matching/localiser.h"
#include "common/util/version.h"

namespace {

using sceneloc::Status;
using sceneloc::StatusOr;
namespace v1 = sceneloc::v1;

StatusOr<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return sceneloc::NotFound("cannot read '" + path + "'");
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Why a session started again at this frame, for the answer line ("" when it continued).
const char* StartNote(v1::SessionStart start) {
  switch (start) {
    case v1::NEW:
      return "\t(new session)";
    case v1::RESET:
      return "\t(session reset)";
    case v1::MAP_RELOADED:
      return "\t(map reloaded with other places: session restarted)";
    default:
      return "";
  }
}

void PrintAnswer(const std::string& query, const v1::LocaliseReply& r) {
  if (r.locations().empty()) {
    std::printf("%s\tno match\tmap %s@%llu\n", query.c_str(), r.map().name().c_str(),
                static_cast<unsigned long long>(r.map().generation()));
    return;
  }
  const v1::RankedLocation& best = r.locations(0);
  // The camera the answer was read with, when it is not the tour's (a stated or learnt one).
  char camera[32] = "";
  if (r.camera_scale() > 0 && std::abs(r.camera_scale() - 1.0f) >= 0.005f) {
    std::snprintf(camera, sizeof(camera), "\tcamera x%.2f", r.camera_scale());
  }
  std::printf("%s\t%d\t%s\t%s\tconfidence %.3f\tlikelihood %.4f\tmap %s@%llu\t%.1f ms%s\n",
              query.c_str(), best.index(), best.image_name().c_str(),
              r.decision() == v1::LOCALISED ? "LOCALISED" : "UNKNOWN", r.confidence(),
              best.likelihood(), r.map().name().c_str(),
              static_cast<unsigned long long>(r.map().generation()), r.timings().total_ms(),
              camera);
  if (r.has_session()) {
    const v1::SessionAnswer& s = r.session();
    std::printf(
        "%s\tsession %s frame %u\t%d\t%s\t%s\tprobability %.3f\toff-map %.3f\ttrack support "
        "%.2f\tcamera x%.2f%s\n",
        query.c_str(), s.name().c_str(), s.frames(), s.location(), s.image_name().c_str(),
        s.decision() == v1::LOCALISED ? "LOCALISED" : "UNKNOWN", s.probability(), s.off_map(),
        s.track_support(), s.camera_scale(), StartNote(s.start()));
  }
}

struct KeyFiles {
  std::string own;     // --key: this client's key pair
  std::string server;  // --server-key: the server's public key
};

StatusOr<std::unique_ptr<sceneloc::Client>> Connect(const std::string& server, int timeout_ms,
                                                    int overload_wait_ms, const KeyFiles& keys) {
  sceneloc::ClientOptions options;
  options.timeout_ms = timeout_ms;
  options.overload_wait_ms = overload_wait_ms;
  options.key_file = keys.own;
  options.server_key_file = keys.server;
  return sceneloc::Client::Connect(server, options);
}

int RunKeygen(const std::string& name, const std::string& dir, bool force) {
  auto pair = sceneloc::GenerateKeyPair(name);
  if (!pair.ok()) {
    std::fprintf(stderr, "sceneloc: %s\n", pair.status().message().c_str());
    return 2;
  }
  if (const Status written = sceneloc::WriteKeyPair(*pair, dir, force); !written.ok()) {
    std::fprintf(stderr, "sceneloc: %s\n", written.message().c_str());
    return 2;
  }
  std::printf(
      "wrote %s/%s.key (secret: keep it on this machine) and %s/%s.pub\n"
      "for the server's auth.clients file:\n"
      "  - name: %s\n    public_key: \"%s\"\n",
      dir.c_str(), name.c_str(), dir.c_str(), name.c_str(), name.c_str(), pair->public_key.c_str());
  return 0;
}

// Localises each input (a JPEG or a feature-set file); returns the exit status.
int RunLocalise(sceneloc::Client* client, const std::string& map,
                const std::vector<std::string>& inputs, bool features,
                sceneloc::LocaliseOptions options) {
  int status = 0;
  for (const std::string& input : inputs) {
    auto bytes = ReadFile(input);
    if (!bytes.ok()) {
      std::fprintf(stderr, "sceneloc: %s\n", bytes.status().message().c_str());
      return 2;
    }
    StatusOr<v1::LocaliseReply> reply = sceneloc::InvalidArgument("unreachable");
    if (features) {
      v1::Request request;
      request.mutable_localise()->set_map(map);
      request.mutable_localise()->set_top_k(options.top_k);
      if (options.min_confidence) {
        request.mutable_localise()->set_min_confidence(*options.min_confidence);
      }
      if (options.camera_scale) request.mutable_localise()->set_camera_scale(*options.camera_scale);
      request.mutable_localise()->set_session(options.session);
      request.mutable_localise()->set_reset_session(options.reset_session);
      if (!request.mutable_localise()->mutable_features()->ParseFromString(*bytes)) {
        std::fprintf(stderr, "sceneloc: '%s' is not a feature-set file\n", input.c_str());
        return 2;
      }
      auto raw = client->Call(std::move(request));
      reply = !raw.ok()                 ? StatusOr<v1::LocaliseReply>(raw.status())
              : raw->status() != v1::OK ? StatusOr<v1::LocaliseReply>(sceneloc::ReplyStatus(*raw))
                                        : StatusOr<v1::LocaliseReply>(raw->localise());
    } else {
      reply = client->Localise(map, *bytes, options);
    }
    options.reset_session = false;  // --reset-session: before the first input only
    if (!reply.ok()) {
      std::printf("%s\terror\t%s\n", input.c_str(), reply.status().message().c_str());
      status = 1;
      continue;
    }
    PrintAnswer(input, *reply);
  }
  return status;
}

int RunExtract(const std::string& image_path, const std::string& out_path,
               const sceneloc::ClientExtractorSource& source, bool uint8) {
  auto extractor = sceneloc::ClientExtractor::Create(source);
  if (!extractor.ok()) {
    std::fprintf(stderr, "sceneloc: %s\n", extractor.status().message().c_str());
    return 2;
  }
  auto image = sceneloc::ReadImageFile(image_path);
  if (!image.ok()) {
    std::fprintf(stderr, "sceneloc: %s\n", image.status().message().c_str());
    return 2;
  }
  auto features = extractor->Extract(*image);
  if (!features.ok()) {
    std::fprintf(stderr, "sceneloc: %s: %s\n", image_path.c_str(),
                 features.status().message().c_str());
    return 1;
  }
  v1::FeatureSet wire;
  sceneloc::EncodeFeatureSet(
      *features,
      uint8 ? sceneloc::DescriptorEncoding::kUint8 : sceneloc::DescriptorEncoding::kFloat32, &wire);
  std::ofstream out(out_path, std::ios::binary);
  if (!out || !wire.SerializeToOstream(&out)) {
    std::fprintf(stderr, "sceneloc: cannot write '%s'\n", out_path.c_str());
    return 2;
  }
  std::printf("%s: %d features (%dx%d) -> %s\n", image_path.c_str(), features->size(),
              features->image_width, features->image_height, out_path.c_str());
  return 0;
}

void PrintMaps(const google::protobuf::RepeatedPtrField<v1::MapInfo>& maps) {
  for (const v1::MapInfo& m : maps) {
    std::printf(
        "%s\tgeneration %llu\tchecksum %08x\t%d locations\t%d landmarks\t%.1f MB\t%s\t"
        "confidence %s (±%d)\ttrained by %s\n",
        m.version().name().c_str(), static_cast<unsigned long long>(m.version().generation()),
        m.version().checksum(), m.num_locations(), m.num_landmarks(),
        static_cast<double>(m.memory_bytes()) / 1e6, m.loaded_utc().c_str(),
        m.confidence_model().c_str(), m.tolerance(),
        m.trained_by().empty() ? "an unknown version" : m.trained_by().c_str());
  }
}

// Prints `status` as the command's error and returns exit status `code`.
int Error(const Status& status, int code) {
  std::fprintf(stderr, "sceneloc: %s\n", status.message().c_str());
  return code;
}

int RunMaps(sceneloc::Client* client) {
  auto reply = client->ListMaps();
  if (!reply.ok()) return Error(reply.status(), 1);
  PrintMaps(reply->maps());
  return 0;
}

int RunReload(sceneloc::Client* client, const std::string& map) {
  auto reply = client->Reload(map);
  if (!reply.ok()) return Error(reply.status(), 1);
  PrintMaps(google::protobuf::RepeatedPtrField<v1::MapInfo>(&reply->map(), &reply->map() + 1));
  return 0;
}

int RunStats(sceneloc::Client* client) {
  auto reply = client->Stats();
  if (!reply.ok()) return Error(reply.status(), 1);
  std::printf("%s", reply->DebugString().c_str());
  return 0;
}

// Everything the command line sets, for every subcommand.
struct CommandLine {
  std::string server, map, out;
  std::vector<std::string> inputs;
  bool features = false, uint8 = true;  // uint8: extract's descriptors (--float32: false)
  int timeout_ms = 10000;
  int overload_wait_ms = sceneloc::ClientOptions().overload_wait_ms;
  sceneloc::LocaliseOptions localise_options;
  float min_confidence = -1;
  float camera_scale = -1;
  sceneloc::ClientExtractorSource extract_source;
  KeyFiles keys;
  sceneloc::BenchArgs bench_args;
  std::string key_name, key_dir = ".";
  bool force = false;
  sceneloc::FramesArgs frames;
};

// The subcommands, to ask which one was given.
struct Commands {
  CLI::App* localise;
  CLI::App* extract;
  CLI::App* maps;
  CLI::App* reload;
  CLI::App* stats;
  CLI::App* bench;
  CLI::App* keygen;
  CLI::App* frames;
};

CLI::App* AddLocalise(CLI::App* app, CommandLine* c) {
  CLI::App* localise = app->add_subcommand("localise", "localise images (or feature sets)");
  localise->add_option("--server", c->server, "server endpoint, e.g. tcp://localhost:5555")
      ->required();
  localise->add_option("--map", c->map, "map name")->required();
  localise->add_flag("--features", c->features,
                     "the inputs are feature-set files (sceneloc extract)");
  localise->add_option("--top-k", c->localise_options.top_k,
                       "ranked locations wanted (0 = server default)");
  localise
      ->add_option("--min-confidence", c->min_confidence,
                   "answers below this are UNKNOWN (default: the server's)")
      ->check(CLI::Range(0.0, 1.0));
  localise
      ->add_option("--camera-scale", c->camera_scale,
                   "the robot camera's focal length over image width against the tour "
                   "camera's, when known (e.g. 1.33: a 4:3 crop of a 16:9 tour camera's sensor); "
                   "default: the tour's, or in a session what it learns")
      ->check(CLI::Validator(
          [](std::string& text) {
            double x = 0;
            const bool ok =
                CLI::detail::lexical_cast(text, x) && sceneloc::CheckCameraScale(x).ok();
            return ok ? std::string() : "must be a number in " + sceneloc::CameraScaleRange();
          },
          "in " + sceneloc::CameraScaleRange()));
  localise->add_option("--session", c->localise_options.session,
                       "send the inputs in order as one session (e.g. the robot's name); each "
                       "answer adds the session's filtered one");
  localise->add_flag("--reset-session", c->localise_options.reset_session,
                     "with --session: forget the session's past before the first input");
  localise->add_option("--timeout-ms", c->timeout_ms, "per attempt");
  localise->add_option("inputs", c->inputs, "JPEG images, or feature-set files with --features")
      ->required();
  return localise;
}

// The options that choose how a client extracts feature sets (extract, bench --features):
// the extractor's settings and the descriptors' encoding. `when` prefixes each help text
// ("with --features: " where they only apply with another flag).
void AddExtractorOptions(CLI::App* sub, const std::string& when, std::string* map_file,
                         std::string* config, int* working_size, bool* uint8) {
  sub->add_option("--map-file", *map_file,
                  when + "extract as the server would for this map (its settings and frame)");
  sub->add_option("--config", *config,
                  when + "training settings whose extractor: section to use (without --map-file)");
  sub->add_option(
      "--working-size", *working_size,
      when + "override extractor.working_size, long side in pixels (without --map-file)");
  CLI::Option* exact = sub->add_flag_callback(
      "--float32", [uint8] { *uint8 = false; }, when + "descriptors as float32 (exact, 4x larger)");
  sub->add_flag("--uint8")
      ->description(when + "descriptors as uint8 (the default)")
      ->excludes(exact);
}

CLI::App* AddExtract(CLI::App* app, CommandLine* c) {
  CLI::App* extract = app->add_subcommand("extract", "compute an image's feature set locally");
  extract->add_option("image", c->inputs, "image file")->required()->expected(1);
  extract->add_option("--out", c->out, "feature-set file to write")->required();
  AddExtractorOptions(extract, "", &c->extract_source.map_file, &c->extract_source.config,
                      &c->extract_source.working_size, &c->uint8);
  return extract;
}

// The options of every command that talks to a server: how long to wait out overload
// replies, and the CURVE keys.
void AddConnectionOptions(CLI::App* sub, CommandLine* c) {
  sub->add_option("--overload-wait-ms", c->overload_wait_ms,
                  "longest to wait out OVERLOADED replies (retrying after the server's hint)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--key", c->keys.own, "CURVE: this client's key pair (sceneloc keygen)");
  sub->add_option("--server-key", c->keys.server, "CURVE: the server's public key (.pub)");
}

CLI::App* AddBench(CLI::App* app, sceneloc::BenchArgs* b) {
  CLI::App* bench = app->add_subcommand("bench", "load generator: N clients for S seconds");
  bench->add_option("--server", b->endpoint, "server endpoint")->required();
  bench->add_option("--map", b->map, "map name")->required();
  bench->add_option("--clients", b->clients, "client threads, one connection each")
      ->capture_default_str();
  bench->add_option("--duration", b->duration_s, "seconds to send requests for")
      ->capture_default_str();
  bench->add_flag("--features", b->features,
                  "extract feature sets once on the client and send those instead of JPEGs");
  AddExtractorOptions(bench, "with --features: ", &b->map_file, &b->config, &b->working_size,
                      &b->uint8);
  bench->add_flag("--sessions", b->sessions,
                  "each client thread is one robot's session through the folder in order");
  bench->add_option("--json", b->json_out, "write the results as JSON to this file");
  bench->add_option("--top-k", b->top_k, "ranked locations wanted (0 = server default)");
  bench->add_option("--timeout-ms", b->timeout_ms, "per attempt")->capture_default_str();
  bench
      ->add_option("--retries", b->retries,
                   "attempts after a timeout or UNAVAILABLE, each on a fresh socket (0: none, "
                   "so failures are not hidden)")
      ->capture_default_str();
  bench->add_option("--key", b->key_file, "CURVE: this client's key pair");
  bench->add_option("--server-key", b->server_key_file, "CURVE: the server's public key");
  bench->add_option("dir", b->image_dir, "folder of query images")->required();
  return bench;
}

CLI::App* AddKeygen(CLI::App* app, CommandLine* c) {
  CLI::App* keygen = app->add_subcommand("keygen", "write a CURVE key pair NAME.key, NAME.pub");
  keygen->add_option("name", c->key_name, "key name (a robot, the server, an operator)")
      ->required();
  keygen->add_option("--dir", c->key_dir, "folder to write them to")->capture_default_str();
  keygen->add_flag("--force", c->force, "overwrite existing files");
  return keygen;
}

// Every subcommand and its options, in the order --help lists them.
Commands AddCommands(CLI::App* app, CommandLine* c) {
  Commands cmd;
  cmd.localise = AddLocalise(app, c);
  cmd.extract = AddExtract(app, c);
  cmd.maps = app->add_subcommand("maps", "list the server's maps");
  cmd.reload = app->add_subcommand("reload", "reload a map from the server's maps folder");
  cmd.stats = app->add_subcommand("stats", "the server's counters");
  cmd.frames = app->add_subcommand(
      "frames", "frames the server kept where its maps failed: list, fetch or delete runs");
  for (CLI::App* sub : {cmd.maps, cmd.reload, cmd.stats, cmd.frames}) {
    sub->add_option("--server", c->server, "server endpoint")->required();
    sub->add_option("--timeout-ms", c->timeout_ms, "per attempt");
  }
  for (CLI::App* sub : {cmd.localise, cmd.maps, cmd.reload, cmd.stats, cmd.frames}) {
    AddConnectionOptions(sub, c);
  }
  cmd.frames->add_option("action", c->frames.action, "list, fetch or delete")
      ->required()
      ->check(CLI::IsMember({"list", "fetch", "delete"}));
  cmd.frames->add_option("--map", c->frames.map, "map name (list: every map without it)");
  cmd.frames->add_option("--run", c->frames.run, "one run (fetch: every run without it)");
  cmd.frames->add_option("--out", c->frames.out, "fetch: folder to write the runs to");
  cmd.reload->add_option("--map", c->map, "map name")->required();
  cmd.bench = AddBench(app, &c->bench_args);
  cmd.keygen = AddKeygen(app, c);
  return cmd;
}

// The commands that talk to one server: localise, maps, reload, stats, frames.
int RunOnServer(const Commands& cmd, CommandLine* c) {
  auto client = Connect(c->server, c->timeout_ms, c->overload_wait_ms, c->keys);
  if (!client.ok()) return Error(client.status(), 2);
  if (c->min_confidence >= 0) c->localise_options.min_confidence = c->min_confidence;
  if (c->camera_scale > 0) c->localise_options.camera_scale = c->camera_scale;
  if (cmd.localise->parsed()) {
    return RunLocalise(client->get(), c->map, c->inputs, c->features, c->localise_options);
  }
  if (cmd.maps->parsed()) return RunMaps(client->get());
  if (cmd.reload->parsed()) return RunReload(client->get(), c->map);
  if (cmd.frames->parsed()) return sceneloc::RunFrames(client->get(), c->frames);
  return RunStats(client->get());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc: client of sceneloc-server"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  app.require_subcommand(1);
  CommandLine c;
  const Commands cmd = AddCommands(&app, &c);
  CLI11_PARSE(app, argc, argv);
  if (cmd.extract->parsed()) return RunExtract(c.inputs[0], c.out, c.extract_source, c.uint8);
  if (cmd.bench->parsed()) return sceneloc::RunBench(c.bench_args);
  if (cmd.keygen->parsed()) return RunKeygen(c.key_name, c.key_dir, c.force);
  return RunOnServer(cmd, &c);
}
