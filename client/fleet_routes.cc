#include "client/fleet_routes.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <filesystem>

#include "common/map/map_name.h"

namespace sceneloc {

StatusOr<std::string> FleetRoutes::EndpointOf(const std::string& map) const {
  const auto it = maps.find(map);
  if (it != maps.end()) return it->second;
  if (!fallback.empty()) return fallback;
  return NotFound("no map named '" + map + "' in the routes file " + source +
                  " (and no default: endpoint)");
}

std::vector<std::string> FleetRoutes::Endpoints() const {
  std::vector<std::string> out;
  if (!fallback.empty()) out.push_back(fallback);
  for (const auto& [map, endpoint] : maps) {
    if (std::find(out.begin(), out.end(), endpoint) == out.end()) out.push_back(endpoint);
  }
  return out;
}

StatusOr<FleetRoutes> ReadFleetRoutes(const std::string& path) {
  if (!std::filesystem::is_regular_file(path)) {
    return NotFound("routes file " + path + " cannot be read");
  }
  FleetRoutes routes;
  routes.source = path;
  auto bad = [&](const std::string& why) {
    return InvalidArgument("routes file " + path + ": " + why);
  };
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::Exception& e) {
    return bad(std::string("not valid YAML: ") + e.what());
  }
  if (!root.IsMap()) return bad("expected keys maps: and default:");
  for (const auto& entry : root) {
    const std::string key = entry.first.as<std::string>("");
    if (key == "default") {
      if (!entry.second.IsScalar()) return bad("default: must be an endpoint");
      routes.fallback = entry.second.as<std::string>();
      if (routes.fallback.empty()) return bad("default: is empty");
    } else if (key == "maps") {
      if (!entry.second.IsMap()) return bad("maps: must map each map name to an endpoint");
      for (const auto& route : entry.second) {
        const std::string map = route.first.as<std::string>("");
        if (const std::string problem = MapNameProblem(map); !problem.empty()) {
          return bad("'" + map + "': " + problem);
        }
        if (!route.second.IsScalar() || route.second.as<std::string>().empty()) {
          return bad("map '" + map + "' has no endpoint");
        }
        routes.maps[map] = route.second.as<std::string>();
      }
    } else {
      return bad("unknown key '" + key + "' (known: maps, default)");
    }
  }
  if (routes.maps.empty() && routes.fallback.empty()) return bad("no routes (maps: or default:)");
  return routes;
}

}  // namespace sceneloc
