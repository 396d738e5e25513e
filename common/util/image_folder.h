// Listing the images of a tour or query folder.
#pragma once

#include <string>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// Regular files of `dir` in file-name order, hidden files (".name") skipped. Every listed
// file is expected to be an image; callers report a file that does not decode. Errors: the
// folder is missing, not a folder, unreadable, or holds no file.
StatusOr<std::vector<std::string>> ListImageFiles(const std::string& dir);

// The file name of a path ("/a/b/Image042.jpg" -> "Image042.jpg").
std::string FileName(const std::string& path);

}  // namespace sceneloc
