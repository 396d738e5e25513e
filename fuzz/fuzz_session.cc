// libFuzzer target: a session's state as a client carries it back (server/session_token.h),
// bytes the server reads in every request that continues a session. The first byte picks
// the mode (fuzz_world.h): the token as it is, or with its CRC made right so the fuzzer
// gets past the checksum into the counts, the tracked locations and the values; and the
// filter it must fit, keeping every location's speeds or only a few.
//
// Oracle beyond the sanitizers: a token that parses as this map's seeds the filter as the
// server would (SequenceFilter::Update): the state fits the filter before and after, the
// answer is a location of the map with a probability in [0, 1], and the state after it
// survives its own round trip.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "common/map/crc32.h"
#include "common/matching/sequence_filter.h"
#include "fuzz/fuzz_world.h"
#include "server/session_token.h"

namespace sceneloc {
namespace {

struct Fixture {
  Map map;
  std::unique_ptr<SequenceFilter> every;  // keeps every location's speeds
  std::unique_ptr<SequenceFilter> few;    // keeps kSessionFewTracked locations' speeds
};

const Fixture& TheFixture() {
  static const Fixture* fixture = [] {
    auto world = fuzz::MakeFuzzWorld();
    if (!world.ok()) {
      std::fprintf(stderr, "fuzz_session: %s\n", world.status().ToString().c_str());
      std::abort();
    }
    auto* f = new Fixture;
    f->map = std::move(world->map);
    f->every = std::make_unique<SequenceFilter>(f->map, SequenceOptions());
    SequenceOptions few;
    few.tracked_locations = fuzz::kSessionFewTracked;
    f->few = std::make_unique<SequenceFilter>(f->map, few);
    return f;
  }();
  return *fixture;
}

void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz_session: %s\n", what);
  std::abort();
}

}  // namespace
}  // namespace sceneloc

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace sceneloc;
  if (size < 1) return 0;
  const Fixture& f = TheFixture();
  const uint8_t mode = data[0];
  std::string bytes(reinterpret_cast<const char*>(data) + 1, size - 1);
  if ((mode & fuzz::kSessionModeFixCrc) != 0 && bytes.size() >= 4) {
    const uint32_t crc = Crc32(bytes.data(), bytes.size() - 4);
    std::memcpy(&bytes[bytes.size() - 4], &crc, 4);
  }
  const SequenceFilter& filter = (mode & fuzz::kSessionModeFewTracked) != 0 ? *f.few : *f.every;
  const int n = f.map.num_images();
  const TokenOwner owner{fuzz::kSessionClient, fuzz::kSessionName, fuzz::kSessionMapChecksum, n,
                         filter.num_speeds()};
  SequenceState state;
  const auto fit = ParseSessionToken(bytes, owner, &state);
  if (!fit.ok() || *fit != TokenFit::kFits) return 0;
  Check(filter.Fits(state), "a parsed state does not fit its filter");
  FrameEvidence evidence;  // a frame that looks most like location 1
  evidence.in_map = 0.9;
  for (int l = 0; l < n; ++l) evidence.location_scores.push_back(l == 1 ? 5.0f : 0.1f * l);
  const SequenceAnswer a = filter.Update(evidence, &state);
  Check(a.location >= 0 && a.location < n, "the answer is not a location of the map");
  Check(a.probability >= 0 && a.probability <= 1 + 1e-4, "the probability is not in [0, 1]");
  Check(filter.Fits(state), "the state after an update does not fit its filter");
  SequenceState again;
  const auto round_trip = ParseSessionToken(SerializeSessionToken(state, owner), owner, &again);
  Check(round_trip.ok() && *round_trip == TokenFit::kFits, "the state after it does not parse");
  return 0;
}
