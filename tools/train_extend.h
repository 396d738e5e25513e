// sceneloc-train --extend: adds a walk to a map (common/training/extend.h) and reports what
// it added.
#pragma once

#include <string>

namespace sceneloc {

struct ExtendArgs {
  std::string map_path;  // the map to extend (read, never written)
  std::string walk_dir;  // the walk's images, in walk order by file name
  std::string out_path;  // the extended map
  std::string name;      // the experience's name ("" = the walk folder's)
  std::string spool_dir;
  std::string frames_csv;  // where to write what became of each frame ("" = nowhere)
  bool new_ground = false;
  int threads = 1;
};

// Runs the extension; returns the process's exit code (0 done, 1 failed; the reason on
// stderr). The caller has checked that out_path can be written.
int ExtendCommand(const ExtendArgs& args);

}  // namespace sceneloc
