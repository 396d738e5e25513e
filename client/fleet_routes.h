// A fleet laid out as groups (docs/operations.md "A fleet"): one sceneloc-broker per group of maps,
// and a routes file that says which broker serves which map. Client::Connect takes "routes:FILE" as
// its endpoint and sends each request to its map's broker, so every tool and robot reaches a fleet
// of groups through one setting.
//
// The routes file (YAML):
//   maps:                          # map name -> the endpoint of the broker serving it
//     gardens: tcp://broker-a:5555
//     corridor: tcp://broker-b:5555
//   default: tcp://broker-a:5555   # optional: maps not listed, and list_maps / stats
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/util/status.h"

namespace sceneloc {

// The prefix of an endpoint that names a routes file.
inline constexpr char kRoutesPrefix[] = "routes:";

struct FleetRoutes {
  std::map<std::string, std::string> maps;  // map name -> endpoint
  std::string fallback;                     // `default:`; empty for none
  std::string source;                       // the file it was read from, for errors

  // The endpoint serving `map`: its entry, else the default. NotFound naming the file
  // when neither exists.
  StatusOr<std::string> EndpointOf(const std::string& map) const;
  // Every distinct endpoint, the default first when there is one.
  std::vector<std::string> Endpoints() const;
};

// Reads a routes file. Errors name the file and what is wrong: a file that cannot be read
// (NotFound), bad YAML, an unknown key, an empty name or endpoint, no routes at all
// (InvalidArgument).
StatusOr<FleetRoutes> ReadFleetRoutes(const std::string& path);

}  // namespace sceneloc
