// The ctest fixture server/TrainSyntheticMap: trains the shared test map afresh, so the
// tests of this run never use a map left by an older build, and writes one of its tour's
// JPEGs beside the maps folder (query.jpg) for tests that run programs on files.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "tests/server/server_test_support.h"

int main() {
  sceneloc::test::TrainTestMapAfresh();
  std::printf("test map: %s\n", sceneloc::test::TestMapPath().c_str());
  const std::filesystem::path query =
      std::filesystem::path(sceneloc::test::TestMapsDir()).parent_path() / "query.jpg";
  std::ofstream(query, std::ios::binary) << sceneloc::test::TourJpegs().at(3);
  std::printf("query: %s\n", query.c_str());
  return 0;
}
