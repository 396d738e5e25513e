#include "common/map/places.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "common/map/crc32.h"

namespace sceneloc {

const char* ExperienceKindName(ExperienceKind kind) {
  switch (kind) {
    case ExperienceKind::kTour:
      return "tour";
    case ExperienceKind::kRoute:
      return "route";
    case ExperienceKind::kNewGround:
      return "new ground";
  }
  return "unknown";
}

std::vector<std::string> Map::PlaceNames() const {
  std::vector<std::string> names;
  names.reserve(static_cast<size_t>(num_places()));
  for (int p = 0; p < num_places(); ++p) names.push_back(PlaceName(p));
  return names;
}

size_t CountPlaces(const Map& map) {
  if (map.image_place.empty()) return map.image_names.size();
  return static_cast<size_t>(*std::max_element(map.image_place.begin(), map.image_place.end())) + 1;
}

namespace {

Status ValidateImagePlaces(const Map& map) {
  const size_t n = map.image_names.size();
  if (map.image_place.empty()) return Status::Ok();
  if (map.image_place.size() != n) {
    return DataLoss("image_place has " + std::to_string(map.image_place.size()) + " entries for " +
                    std::to_string(n) + " images");
  }
  // Each place's first image, in increasing order of place: place p + 1 first appears after
  // place p does, so a place is never named before the places before it.
  uint32_t next = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t p = map.image_place[i];
    if (p > next) {
      return DataLoss("image " + std::to_string(i) + " shows place " + std::to_string(p) +
                      " before any image shows place " + std::to_string(next));
    }
    if (p == next) ++next;
  }
  return Status::Ok();
}

Status ValidateExperiences(const Map& map) {
  if (map.experiences.empty()) return Status::Ok();
  uint64_t next = 0;
  for (size_t e = 0; e < map.experiences.size(); ++e) {
    const Experience& x = map.experiences[e];
    const std::string which = "experience " + std::to_string(e) + " ('" + x.name + "')";
    if (x.first_image != next || x.num_images == 0) {
      return DataLoss(which + " does not follow the one before it or has no images");
    }
    if (x.kind != ExperienceKind::kTour && x.kind != ExperienceKind::kRoute &&
        x.kind != ExperienceKind::kNewGround) {
      return DataLoss(which + " is of an unknown kind " +
                      std::to_string(static_cast<uint32_t>(x.kind)));
    }
    const Calibration& c = x.calibration;
    if (c.valid && !(std::isfinite(c.off_map_distance) && c.off_map_distance >= 0 &&
                     std::isfinite(c.off_map_spread) && c.off_map_spread > 0)) {
      return DataLoss(which + ": its off-map level must be finite, its spread > 0");
    }
    if ((e == 0) != (x.kind == ExperienceKind::kTour)) {
      return DataLoss(which + ": the first experience, and only it, is the tour");
    }
    next += x.num_images;
  }
  if (next != map.image_names.size()) {
    return DataLoss("the experiences cover " + std::to_string(next) + " images of " +
                    std::to_string(map.image_names.size()));
  }
  return Status::Ok();
}

}  // namespace

Status ValidatePlaces(const Map& map) {
  SCENELOC_RETURN_IF_ERROR(ValidateImagePlaces(map));
  return ValidateExperiences(map);
}

void DerivePlaces(Map* map) {
  map->place_image.clear();
  for (size_t i = 0; i < map->image_place.size(); ++i) {
    if (map->image_place[i] == map->place_image.size()) {
      map->place_image.push_back(static_cast<uint32_t>(i));
    }
  }
}

uint32_t Map::PlacesKey() const {
  const bool walks = !experiences.empty();
  const std::string tour = (walks ? experiences.front().created_utc : provenance.created_utc) +
                           '\n' + (walks ? experiences.front().name : provenance.tour_dir) + '\n';
  uint32_t crc = Crc32(tour.data(), tour.size());
  for (int p = 0; p < num_places(); ++p) {
    const std::string name = PlaceName(p) + '\n';
    crc = Crc32(name.data(), name.size(), crc);
  }
  return crc;
}

}  // namespace sceneloc
