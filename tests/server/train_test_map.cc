// The ctest fixture server/TrainSyntheticMap: trains the shared test map afresh, so the
// tests of this run never use a map left by an older build.
#include <cstdio>

#include "tests/server/server_test_support.h"

int main() {
  sceneloc::test::TrainTestMapAfresh();
  std::printf("test map: %s\n", sceneloc::test::TestMapPath().c_str());
  return 0;
}
