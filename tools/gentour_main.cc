// sceneloc-gentour: writes a synthetic training tour and a test pass of the same route,
// so the pipeline can be tried end to end without real images.
//   sceneloc-gentour --out DIR [--locations N] [--width W] [--height H] [--seed S]
//                    [--passes tour|test|both] [--threads N]
// writes DIR/tour/Image000.jpg ... (pass 0) and DIR/test/Image000.jpg ... (pass 1).
// Exit status: 0 on success, 1 on any error (one line on stderr).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "common/synthetic/tour_generator.h"
#include "common/util/version.h"

namespace {

int Fail(const std::string& message) {
  std::fprintf(stderr, "sceneloc-gentour: %s\n", message.c_str());
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"sceneloc-gentour: write a synthetic training tour and test pass"};
  app.set_version_flag("--version", std::string(sceneloc::Version()));
  std::string out_dir;
  sceneloc::TourOptions options;
  app.add_option("--out", out_dir, "output folder; gets tour/ and test/ sub-folders")->required();
  app.add_option("--locations", options.num_locations, "images per pass")->capture_default_str();
  app.add_option("--width", options.image_width, "image width in pixels")->capture_default_str();
  app.add_option("--height", options.image_height, "image height in pixels")->capture_default_str();
  app.add_option("--seed", options.seed, "scene seed; the same seed gives the same images")
      ->capture_default_str();
  std::string passes = "both";
  app.add_option("--passes", passes, "which passes to write: tour, test or both")
      ->check(CLI::IsMember({"tour", "test", "both"}))
      ->capture_default_str();
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  app.add_option("--repeat-blocks", options.repeat_blocks,
                 "look-alike places: the street repeats every N blocks of 40 m, each facade "
                 "tile keeping one small sign of its own (0 = never)")
      ->capture_default_str();
  app.add_option("--threads", threads, "rendering threads (the images do not depend on it)")
      ->check(CLI::Range(1, 256));
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    // CLI11's own report spans several lines and exit codes; keep ours to one line and 1.
    return Fail(e.what());
  }

  if (const sceneloc::Status valid = options.Validate(); !valid.ok()) {
    return Fail("invalid options: " + valid.message());
  }
  std::vector<std::pair<std::string, int>> wanted;
  if (passes != "test") wanted.emplace_back(out_dir + "/tour", sceneloc::kTrainingPass);
  if (passes != "tour") wanted.emplace_back(out_dir + "/test", sceneloc::kTestPass);
  for (const auto& [dir, pass] : wanted) {
    if (const sceneloc::Status written = sceneloc::WriteTour(options, dir, pass, threads);
        !written.ok()) {
      return Fail(written.message());
    }
    std::printf("wrote %d %s images to %s (%dx%d, seed %u)\n", options.num_locations,
                pass == sceneloc::kTrainingPass ? "training" : "test", dir.c_str(),
                options.image_width, options.image_height, options.seed);
  }
  return 0;
}
