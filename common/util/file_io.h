// Whole-file reads, and writes that leave a file holding either its old content or the whole
// new one (a temporary file beside it, fsynced, renamed over it, the folder fsynced): what
// map files, generated images and plots are written with.
//
// Thread-safe: free functions without shared state (the temporary file's name carries the
// process id; two threads of one process must not write the same path at once).
#pragma once

#include <string>
#include <string_view>

#include "common/util/status.h"

namespace sceneloc {

// IoError "<what> '<path>': <strerror(error)>".
Status OsError(const std::string& what, const std::string& path, int error);

// Writes `bytes` to `path + ".tmp.<pid>"`, fsyncs it, renames it over `path` and fsyncs
// the folder. On failure the temporary file is removed and the status (IoError) names
// the path and the OS error.
Status WriteFileAtomically(const std::string& path, std::string_view bytes);

// Reads a whole file; NotFound when it is missing or not a regular file, IoError otherwise.
StatusOr<std::string> ReadFileBytes(const std::string& path);

}  // namespace sceneloc
