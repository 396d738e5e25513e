// The thinnest robot: sends a feature-set file (`sceneloc extract IMAGE --out FILE`, or a
// serialised sceneloc.v1.FeatureSet made on board) to a server and prints the answer.
//
//   sceneloc-thin-client ENDPOINT MAP FEATURES_FILE
//
// It links sceneloc_client alone — protobuf, ZeroMQ and Eigen, no OpenCV — which the ctest
// client/ThinClientLinksNoOpenCV checks on the built binary. Exit status 0 on an answer
// (LOCALISED or UNKNOWN), 1 on an error, 2 on bad usage.
#include <cstdio>
#include <fstream>
#include <sstream>

#include "client/client.h"
#include "proto/wire.h"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s ENDPOINT MAP FEATURES_FILE\n", argv[0]);
    return 2;
  }
  std::ifstream in(argv[3], std::ios::binary);
  sceneloc::v1::FeatureSet wire;
  if (!in || !wire.ParseFromIstream(&in)) {
    std::fprintf(stderr, "cannot read a feature set from '%s'\n", argv[3]);
    return 1;
  }
  auto features = sceneloc::DecodeFeatureSet(wire, sceneloc::FeatureSetLimits{});
  if (!features.ok()) {
    std::fprintf(stderr, "%s: %s\n", argv[3], features.status().message().c_str());
    return 1;
  }
  auto client = sceneloc::Client::Connect(argv[1]);
  if (!client.ok()) {
    std::fprintf(stderr, "%s\n", client.status().message().c_str());
    return 1;
  }
  auto answer = (*client)->Localise(argv[2], *features);
  if (!answer.ok()) {
    std::fprintf(stderr, "%s\n", answer.status().ToString().c_str());
    return 1;
  }
  std::printf("location %d (%s), confidence %.2f, %s\n", answer->locations(0).index(),
              answer->locations(0).image_name().c_str(), answer->confidence(),
              sceneloc::v1::Decision_Name(answer->decision()).c_str());
  return 0;
}
