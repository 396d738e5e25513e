// `sceneloc frames`: the frames a server kept where its maps failed (server/frame_keeper.h,
// docs/experiences.md), as an operator reads them.
//   sceneloc frames list   --server EP [--map NAME]           one line per run
//   sceneloc frames fetch  --server EP --map NAME [--run RUN] --out DIR
//        writes DIR/<run>/000000.jpg ... and DIR/<run>.yaml for the run (every run of the
//        map without --run), page by page; DIR/<run> is a walk for sceneloc-train --extend
//   sceneloc frames delete --server EP --map NAME --run RUN    frees its quota
#pragma once

#include <string>

#include "client/client.h"

namespace sceneloc {

struct FramesArgs {
  std::string action;  // list, fetch or delete
  std::string map;
  std::string run;
  std::string out;
};

// Runs the action on `client`; returns the exit status: 0 done, 1 an error reply or none,
// 2 bad arguments or a file that cannot be written.
int RunFrames(Client* client, const FramesArgs& args);

}  // namespace sceneloc
