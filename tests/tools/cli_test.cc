// sceneloc-train and sceneloc-eval as a user runs them: every bad input gets one clear
// error line naming the file and the problem, a non-zero exit, and no map file.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/map/map_io.h"
#include "common/synthetic/tour_generator.h"

namespace sceneloc {
namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

RunResult RunCommand(const std::string& command) {
  RunResult r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return r;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) r.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

class CliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(::testing::TempDir()) / ("sceneloc_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    TourOptions tour;
    tour.num_locations = 8;
    ASSERT_TRUE(WriteTour(tour, (dir_ / "tour").string(), kTrainingPass).ok());
    ASSERT_TRUE(WriteTour(tour, (dir_ / "test").string(), kTestPass).ok());
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static std::string Train(const std::string& tour, const std::string& out,
                           const std::string& extra = "") {
    return std::string(SCENELOC_TRAIN_BIN) + " --tour '" + tour + "' --out '" + out + "' " + extra;
  }
  // Expects a failed run with exactly one line of output mentioning every `needle`.
  static void ExpectOneLineError(const RunResult& r, const std::vector<std::string>& needles) {
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
    for (const auto& n : needles) EXPECT_NE(r.output.find(n), std::string::npos) << r.output;
  }

  static fs::path dir_;
};

fs::path CliTest::dir_;

// --version: one line, the same from every tool of one build, the project's version first.
std::string VersionOf(const std::string& binary) {
  RunResult r = RunCommand(binary + " --version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(std::count(r.output.begin(), r.output.end(), '\n'), 1) << r.output;
  EXPECT_EQ(r.output.rfind("0.", 0), 0u) << r.output;
  if (!r.output.empty()) r.output.pop_back();
  return r.output;
}

TEST_F(CliTest, EveryToolReportsItsVersion) {
  const std::string version = VersionOf(SCENELOC_TRAIN_BIN);
  EXPECT_EQ(VersionOf(SCENELOC_EVAL_BIN), version);
  EXPECT_EQ(VersionOf(SCENELOC_ACCURACY_BIN), version);
}

// The happy path: train writes a loadable map that records the version that trained it,
// and eval prints match rates for it.
TEST_F(CliTest, TrainThenEval) {
  const std::string map = (dir_ / "ok.scnl").string();
  RunResult r = RunCommand(Train((dir_ / "tour").string(), map,
                                 "--config " SCENELOC_CONFIGS_DIR "/train.yaml --threads 2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("landmarks kept"), std::string::npos);
  const auto trained = LoadMap(map);
  ASSERT_TRUE(trained.ok());
  EXPECT_EQ(trained->provenance.tool_version, VersionOf(SCENELOC_TRAIN_BIN));
  const std::string json = (dir_ / "eval.json").string();
  r = RunCommand(std::string(SCENELOC_EVAL_BIN) + " --map '" + map + "' --queries '" +
                 (dir_ / "test").string() + "' --baseline --json '" + json + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("baseline"), std::string::npos);
  std::ifstream in(json);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* key : {"\"match_rate\"", "\"lean\"", "\"mean_confidence\"", "\"timing_ms\"",
                          "\"extract\"", "\"p90\"", "\"baseline\"", "\"per_query\""}) {
    EXPECT_NE(text.find(key), std::string::npos) << key;
  }
}

// eval --sequence: the test pass in file order as one session, the single-frame row beside;
// --kidnap: shuffled segments, frames to find the robot again per jump, in the JSON too.
TEST_F(CliTest, EvalSequenceAndKidnap) {
  const std::string map = (dir_ / "seq.scnl").string();
  RunResult r = RunCommand(Train((dir_ / "tour").string(), map, "--threads 2"));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const std::string eval = std::string(SCENELOC_EVAL_BIN) + " --map '" + map + "' --queries '" +
                           (dir_ / "test").string() + "' ";
  r = RunCommand(eval + "--sequence");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\nsingle "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("as one session"), std::string::npos) << r.output;
  const std::string json = (dir_ / "kidnap.json").string();
  r = RunCommand(eval + "--kidnap 3 --seed 2 --json '" + json + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("frames to a correct answer after a jump"), std::string::npos)
      << r.output;
  std::ifstream in(json);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const char* key : {"\"session\"", "\"single_frame\"", "\"frames_to_correct\"",
                          "\"frames_to_localised\"", "\"single_predicted\""}) {
    EXPECT_NE(text.find(key), std::string::npos) << key;
  }
  r = RunCommand(eval + "--kidnap 1");
  EXPECT_NE(r.exit_code, 0) << r.output;  // one segment is no kidnap
}

// A missing tour folder, an empty one and a one-image tour.
TEST_F(CliTest, BadTourFolders) {
  const std::string out = (dir_ / "never.scnl").string();
  ExpectOneLineError(RunCommand(Train((dir_ / "nope").string(), out)), {"nope", "does not exist"});
  fs::create_directories(dir_ / "empty");
  ExpectOneLineError(RunCommand(Train((dir_ / "empty").string(), out)), {"empty", "no image"});
  fs::create_directories(dir_ / "one");
  fs::copy_file(dir_ / "tour" / "Image000.jpg", dir_ / "one" / "Image000.jpg");
  ExpectOneLineError(RunCommand(Train((dir_ / "one").string(), out)), {"one", "at least 2"});
  EXPECT_FALSE(fs::exists(out));
}

// A file that is not an image, and a truncated JPEG, named in the error.
TEST_F(CliTest, UnreadableImages) {
  const std::string out = (dir_ / "never.scnl").string();
  fs::create_directories(dir_ / "notes");
  fs::copy(dir_ / "tour", dir_ / "notes", fs::copy_options::recursive);
  std::ofstream(dir_ / "notes" / "readme.txt") << "not an image\n";
  ExpectOneLineError(RunCommand(Train((dir_ / "notes").string(), out)),
                     {"readme.txt", "not a readable image"});
  fs::create_directories(dir_ / "cut");
  fs::copy(dir_ / "tour", dir_ / "cut", fs::copy_options::recursive);
  fs::resize_file(dir_ / "cut" / "Image003.jpg", 200);
  const RunResult r = RunCommand(Train((dir_ / "cut").string(), out));
  EXPECT_NE(r.exit_code, 0);
  EXPECT_FALSE(fs::exists(out));
}

// Settings files: an unknown key and an out-of-range value, named with the file.
TEST_F(CliTest, BadSettingsFiles) {
  const std::string out = (dir_ / "never.scnl").string();
  const std::string bad_key = (dir_ / "bad_key.yaml").string();
  std::ofstream(bad_key) << "selection:\n  etaa: 3\n";
  ExpectOneLineError(RunCommand(Train((dir_ / "tour").string(), out, "--config '" + bad_key + "'")),
                     {"bad_key.yaml", "unknown key 'selection.etaa'"});
  const std::string bad_value = (dir_ / "bad_value.yaml").string();
  std::ofstream(bad_value) << "tracking:\n  distance_threshold: -1\n";
  ExpectOneLineError(
      RunCommand(Train((dir_ / "tour").string(), out, "--config '" + bad_value + "'")),
      {"bad_value.yaml", "tracking.distance_threshold", "is outside [1e-06, 2]"});
  EXPECT_FALSE(fs::exists(out));
}

// sceneloc-eval on a map of another format version and on a non-map file.
TEST_F(CliTest, EvalRefusesBadMaps) {
  const std::string map = (dir_ / "v99.scnl").string();
  ASSERT_EQ(RunCommand(Train((dir_ / "tour").string(), map)).exit_code, 0);
  {
    std::fstream f(map, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(8);
    const uint32_t version = 99;
    f.write(reinterpret_cast<const char*>(&version), 4);
  }
  const std::string eval =
      std::string(SCENELOC_EVAL_BIN) + " --queries '" + (dir_ / "test").string() + "' --map ";
  ExpectOneLineError(RunCommand(eval + "'" + map + "'"), {"v99.scnl", "format version 99"});
  ExpectOneLineError(RunCommand(eval + "'" + (dir_ / "tour" / "Image000.jpg").string() + "'"),
                     {"Image000.jpg", "not a sceneloc map"});
}

// --upgrade rewrites a map of an older format in today's, which loads the same; a file that
// is not a map, or --upgrade beside --tour, is one line of error and no file.
TEST_F(CliTest, UpgradeRewritesAnOlderMap) {
  const std::string out = (dir_ / "upgraded.scnl").string();
  const RunResult r = RunCommand(std::string(SCENELOC_TRAIN_BIN) + " --upgrade '" +
                                 SCENELOC_TEST_DATA + "/v5_map.scnl' --out '" + out + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("format 5"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("format " + std::to_string(kMapFormatVersion)), std::string::npos);
  MapFileInfo info;
  auto upgraded = LoadMap(out, &info);
  ASSERT_TRUE(upgraded.ok()) << upgraded.status().ToString();
  EXPECT_EQ(info.format_version, kMapFormatVersion);
  auto original = LoadMap(std::string(SCENELOC_TEST_DATA) + "/v5_map.scnl");
  ASSERT_TRUE(original.ok());
  EXPECT_EQ(upgraded->num_landmarks(), original->num_landmarks());
  EXPECT_EQ(upgraded->neighbours.size(), original->neighbours.size());

  const std::string bad = (dir_ / "not_a_map.scnl").string();
  ExpectOneLineError(
      RunCommand(std::string(SCENELOC_TRAIN_BIN) + " --upgrade '" +
                 (dir_ / "tour" / "Image000.jpg").string() + "' --out '" + bad + "'"),
      {"Image000.jpg", "not a sceneloc map"});
  EXPECT_FALSE(fs::exists(bad));
  ExpectOneLineError(RunCommand(Train((dir_ / "tour").string(), bad, "--upgrade '" + out + "'")),
                     {"--upgrade"});
  EXPECT_FALSE(fs::exists(bad));
}

// --extend adds a walk to a map as a user runs it: the summary says what it added, the new
// file holds two walks, and what it refuses (an older format, options that do not go with it,
// an --out it cannot write) it refuses with one line and no file.
TEST_F(CliTest, ExtendAddsAWalkAndRefusesWhatItCannotDo) {
  const std::string map = (dir_ / "to_extend.scnl").string();
  ASSERT_EQ(RunCommand(Train((dir_ / "tour").string(), map)).exit_code, 0);
  const std::string out = (dir_ / "extended.scnl").string();
  const std::string csv = (dir_ / "extended.csv").string();
  const std::string extend = std::string(SCENELOC_TRAIN_BIN) + " --extend '";
  RunResult r = RunCommand(extend + map + "' --tour '" + (dir_ / "test").string() + "' --out '" +
                           out + "' --new-ground --name annex --frames-csv '" + csv + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("with 'annex' (new ground)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("8 new places"), std::string::npos) << r.output;
  auto extended = LoadMap(out);
  ASSERT_TRUE(extended.ok()) << extended.status().ToString();
  EXPECT_EQ(extended->num_places(), 16);
  ASSERT_EQ(extended->experiences.size(), 2u);
  EXPECT_EQ(extended->experiences[1].name, "annex");
  std::ifstream rows(csv);
  EXPECT_EQ(
      std::count(std::istreambuf_iterator<char>(rows), std::istreambuf_iterator<char>(), '\n'),
      9);  // a header and one row a frame

  const std::string bad = (dir_ / "not_extended.scnl").string();
  ExpectOneLineError(RunCommand(extend + SCENELOC_TEST_DATA + "/v5_map.scnl' --tour '" +
                                (dir_ / "test").string() + "' --out '" + bad + "'"),
                     {"v5_map.scnl", "format 5", "--upgrade"});
  ExpectOneLineError(RunCommand(extend + map + "' --tour '" + (dir_ / "test").string() +
                                "' --out '" + bad + "' --eta 5"),
                     {"--extend", "--eta"});
  ExpectOneLineError(RunCommand(extend + map + "' --tour '" + (dir_ / "test").string() +
                                "' --out '" + (dir_ / "no_such_dir" / "m.scnl").string() + "'"),
                     {"no_such_dir", "does not exist"});
  ExpectOneLineError(RunCommand(Train((dir_ / "tour").string(), bad, "--new-ground")),
                     {"--new-ground", "--extend"});
  EXPECT_FALSE(fs::exists(bad));
}

// sceneloc-eval on query folders it cannot use: a non-image file, an empty folder, and a
// query with no tour image of its name.
TEST_F(CliTest, EvalRefusesBadQueryFolders) {
  const std::string map = (dir_ / "q.scnl").string();
  ASSERT_EQ(RunCommand(Train((dir_ / "tour").string(), map)).exit_code, 0);
  const std::string eval = std::string(SCENELOC_EVAL_BIN) + " --map '" + map + "' --queries ";
  fs::create_directories(dir_ / "q_notes");
  fs::copy(dir_ / "test", dir_ / "q_notes", fs::copy_options::recursive);
  std::ofstream(dir_ / "q_notes" / "notes.txt") << "not an image\n";
  ExpectOneLineError(RunCommand(eval + "'" + (dir_ / "q_notes").string() + "'"),
                     {"notes.txt", "not a readable image"});
  fs::create_directories(dir_ / "q_empty");
  ExpectOneLineError(RunCommand(eval + "'" + (dir_ / "q_empty").string() + "'"),
                     {"q_empty", "no image"});
  fs::create_directories(dir_ / "q_stranger");
  fs::copy_file(dir_ / "test" / "Image001.jpg", dir_ / "q_stranger" / "Elsewhere.jpg");
  ExpectOneLineError(RunCommand(eval + "'" + (dir_ / "q_stranger").string() + "'"),
                     {"Elsewhere.jpg", "not a tour image"});
}

// An --out that cannot be written is refused at once, before any image is read: a missing
// folder, a folder given as the file, a read-only folder.
TEST_F(CliTest, UnwritableOutputRefusedFirst) {
  const std::string tour = (dir_ / "tour").string();
  ExpectOneLineError(RunCommand(Train(tour, (dir_ / "no_such_dir" / "m.scnl").string())),
                     {"no_such_dir", "does not exist"});
  ExpectOneLineError(RunCommand(Train(tour, dir_.string())), {"is a folder"});
  if (::geteuid() != 0) {  // root writes anywhere
    fs::create_directories(dir_ / "ro");
    fs::permissions(dir_ / "ro", fs::perms::owner_read | fs::perms::owner_exec);
    ExpectOneLineError(RunCommand(Train(tour, (dir_ / "ro" / "m.scnl").string())),
                       {"ro", "not writable"});
    fs::permissions(dir_ / "ro", fs::perms::owner_all);
  }
}

// A tour of mixed image sizes trains, with a warning, in the first image's frame.
TEST_F(CliTest, MixedSizeTourTrainsWithWarning) {
  fs::create_directories(dir_ / "mixed");
  fs::copy(dir_ / "tour", dir_ / "mixed", fs::copy_options::recursive);
  const cv::Mat image = cv::imread((dir_ / "mixed" / "Image005.jpg").string());
  cv::Mat smaller;
  cv::resize(image, smaller, cv::Size(), 0.75, 0.75, cv::INTER_AREA);
  ASSERT_TRUE(cv::imwrite((dir_ / "mixed" / "Image005.jpg").string(), smaller));
  const std::string map = (dir_ / "mixed.scnl").string();
  const RunResult r = RunCommand(Train((dir_ / "mixed").string(), map));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("1 of 8 tour images differ in size"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("working frame 480x270"), std::string::npos) << r.output;
  EXPECT_TRUE(LoadMap(map).ok());
}

// An image too small to hold a feature is named in the error and no map is written.
TEST_F(CliTest, TinyImageNamed) {
  fs::create_directories(dir_ / "tiny");
  fs::copy(dir_ / "tour", dir_ / "tiny", fs::copy_options::recursive);
  ASSERT_TRUE(cv::imwrite((dir_ / "tiny" / "Image002.jpg").string(),
                          cv::Mat(8, 8, CV_8UC3, cv::Scalar(90, 120, 60))));
  const std::string out = (dir_ / "never.scnl").string();
  ExpectOneLineError(RunCommand(Train((dir_ / "tiny").string(), out)),
                     {"Image002.jpg", "8x8", "too small"});
  EXPECT_FALSE(fs::exists(out));
}

// sceneloc-accuracy refuses a set name that neither suite has, naming it and the sets there
// are (the swapped ones too), before it reads a setting or makes its output folder; with
// no set's folders present it says so.
TEST_F(CliTest, AccuracyRefusesAnUnknownSet) {
  const fs::path data = dir_ / "data";
  fs::create_directories(data / "gardens_point/day_left");
  fs::create_directories(data / "gardens_point/day_right");
  const fs::path out = dir_ / "accuracy-out";
  const std::string accuracy = std::string(SCENELOC_ACCURACY_BIN) + " --data '" + data.string() +
                               "' --out '" + out.string() + "'";
  ExpectOneLineError(RunCommand(accuracy + " --sets gp_day,nope"),
                     {"no set 'nope'", "gp_day, ", "gp_day_roll", "gp_day_swapped", "swapped"});
  EXPECT_FALSE(fs::exists(out));

  const std::string configs = SCENELOC_CONFIGS_DIR;
  const std::string settings = " --config " + configs + "/train.yaml --match-config " + configs +
                               "/match.yaml --paper-config " + configs +
                               "/paper-train.yaml --paper-match-config " + configs +
                               "/paper-match.yaml";
  ExpectOneLineError(
      RunCommand(std::string(SCENELOC_ACCURACY_BIN) + " --data '" + (dir_ / "absent").string() +
                 "' --out '" + out.string() + "' --sets swapped" + settings),
      {"no set to run"});
  EXPECT_FALSE(fs::exists(out));
  // Without the data folder only the generated set would run: said, not run.
  ExpectOneLineError(
      RunCommand(std::string(SCENELOC_ACCURACY_BIN) + " --data '" + (dir_ / "absent").string() +
                 "' --out '" + out.string() + "'" + settings),
      {"no data set under", "absent", "--sets lookalike_street"});
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace sceneloc
