// libFuzzer target: a map file (common/map/map_io.h), the server's most trusted-looking
// untrusted input. The first byte picks the mode (fuzz_world.h): a whole file as it is,
// or a payload behind a valid header, so the fuzzer gets past the checksums into the
// payload parser of either format version.
//
// A map that parses is then used as the server would use it: its self-test query
// (SelfTestFeatures + Localise) must not crash, and it must serialise and parse again.
#include <cstdlib>
#include <string>

#include "common/map/map_io.h"
#include "common/matching/localiser.h"
#include "common/matching/self_test.h"
#include "fuzz/fuzz_world.h"
#include "server/map_registry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace sceneloc;
  if (size < 1) return 0;
  const uint8_t mode = data[0];
  std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  if (mode & 1) bytes = fuzz::WithHeader(bytes, (mode & 2) ? 1 : 2);
  auto map = ParseMap(bytes, "fuzz.scnl");
  if (!map.ok()) return 0;
  if (map->num_images() > 0) {
    (void)Localise(SelfTestFeatures(*map, 0), *map, MatchOptions(), nullptr);
  }
  if (!ParseMap(SerializeMap(*map), "again.scnl").ok()) std::abort();
  return 0;
}
