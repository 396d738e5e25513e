// Listing the images of a tour or query folder.
#pragma once

#include <string>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// Regular files of `dir` in natural file-name order (NaturalLess: frame9.jpg before
// frame10.jpg, Image999.jpg before Image1000.jpg), hidden files (".name") skipped. Every listed
// file is expected to be an image; callers report a file that does not decode. Errors: the
// folder is missing, not a folder, unreadable, or holds no file.
StatusOr<std::vector<std::string>> ListImageFiles(const std::string& dir);

// Whether `a` comes before `b` when runs of digits compare as numbers and everything else
// byte by byte: the order a camera's or sceneloc-gentour's numbered frames were taken in,
// whether or not the numbers are padded to one width. Names equal but for leading zeros
// keep their plain order. A strict weak order.
bool NaturalLess(const std::string& a, const std::string& b);

// The file name of a path ("/a/b/Image042.jpg" -> "Image042.jpg").
std::string FileName(const std::string& path);

// The last component of a folder's path, with or without a trailing separator
// ("/data/gardens_point/day_left/" -> "day_left"); the path itself when it has none.
std::string FolderName(const std::string& dir);

}  // namespace sceneloc
