// Map names: the one rule for what may name a map, used wherever a name arrives (a map
// file in the maps folder, a request, a routes file). A map is served under its file's stem
// ("campus.scnl" -> "campus"), so a name must be a plain file stem that cannot reach outside
// the maps folder: 1-255 characters of [A-Za-z0-9_.-], not starting with '.' (which also
// keeps hidden files and SaveMap's "x.scnl.tmp.<pid>" temporaries out).
//
// Thread-safe: free functions.
#pragma once

#include <string>

namespace sceneloc {

// The extension of map files.
inline constexpr char kMapFileExtension[] = ".scnl";

// Whether `name` may name a map.
bool IsValidMapName(const std::string& name);

// The map name of a file name (no folder) in the maps folder: its stem when it ends in
// kMapFileExtension and the stem is a valid name; "" otherwise (the file is not a map).
std::string MapNameOfFile(const std::string& file_name);

// Why `name` is not a valid map name, for an error message ("" when it is).
std::string MapNameProblem(const std::string& name);

// The file of the map `name` in the maps folder `maps_dir`: <maps_dir>/<name>.scnl.
// REQUIRES: IsValidMapName(name).
std::string MapFilePath(const std::string& maps_dir, const std::string& name);

}  // namespace sceneloc
