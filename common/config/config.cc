#include "common/config/config.h"

#include <yaml-cpp/yaml.h>

#include <fstream>
#include <functional>
#include <sstream>
#include <variant>
#include <vector>

namespace sceneloc {
namespace {

// One settable field: its section and key, where it lives, its allowed range.
struct Field {
  std::string section;
  std::string key;
  std::variant<double*, int*, bool*> target;
  double min = 0;
  double max = 0;
};

std::vector<Field> TrainFields(TrainOptions* o) {
  ExtractorOptions* e = &o->extractor;
  return {
      {"extractor", "max_features", &e->max_features, 0, 100000},
      {"extractor", "image_scale", &e->image_scale, 0.01, 1},
      {"extractor", "context_scale", &e->context_scale, 1.01, 8},
      {"extractor", "contrast_threshold", &e->contrast_threshold, 1e-6, 1},
      {"extractor", "edge_threshold", &e->edge_threshold, 1e-6, 1000},
      {"extractor", "sigma", &e->sigma, 0.1, 10},
      {"extractor", "max_image_side", &e->max_image_side, 16, 65536},
      {"tracking", "distance_threshold", &o->track_distance_threshold, 1e-6, 2},
      {"tracking", "ransac_threshold_px", &o->ransac_threshold_px, 1e-3, 100},
      {"tracking", "ransac_confidence", &o->ransac_confidence, 0.5, 0.999999},
      {"tracking", "min_links_per_pair", &o->min_links_per_pair, 8, 100000},
      {"tracking", "min_track_length", &o->min_track_length, 1, 1000},
      {"landmarks", "local_var_floor", &o->local_var_floor, 1e-9, 4},
      {"landmarks", "context_var_floor", &o->context_var_floor, 1e-9, 4},
      {"landmarks", "distance_var_floor", &o->distance_var_floor, 1e-6, 1e8},
      {"landmarks", "angle_var_floor", &o->angle_var_floor, 1e-9, 40},
      {"landmarks", "max_neighbours", &o->max_neighbours, 0, 256},
      {"selection", "quality_s_min", &o->quality_s_min, 1e-6, 1},
      {"selection", "quality_fp_prior", &o->quality_fp_prior, 0, 1e9},
      {"selection", "eta", &o->eta, 0, 1000000},
      {"selection", "q_min", &o->q_min, 0, 1e9},
  };
}

std::vector<Field> MatchFields(MatchOptions* o) {
  return {
      {"matching", "s_min", &o->s_min, 1e-6, 1},
      {"matching", "use_neighbourhood", &o->use_neighbourhood, 0, 1},
      {"matching", "include_centre_term", &o->include_centre_term, 0, 1},
      {"matching", "max_neighbours", &o->max_neighbours, 0, 256},
      {"matching", "distinctiveness", &o->distinctiveness, 0, 1},
      {"matching", "size_exponent", &o->size_exponent, 0, 2},
      {"matching", "verify_top", &o->verify_top, 0, 1000},
      {"matching", "verify_ransac_px", &o->verify_ransac_px, 0.01, 100},
      {"matching", "verify_ransac_iterations", &o->verify_ransac_iterations, 1, 100000},
      {"matching", "verify_scale_sigma", &o->verify_scale_sigma, 0, 10},
      {"matching", "top_k", &o->top_k, 1, 1000},
  };
}

std::string Where(const std::string& name, const Field& f) {
  return name + ": " + f.section + "." + f.key;
}

Status SetField(const Field& f, const YAML::Node& value, const std::string& name) {
  try {
    if (auto* b = std::get_if<bool*>(&f.target)) {
      **b = value.as<bool>();
      return Status::Ok();
    }
    const double v = value.as<double>();
    if (!(v >= f.min && v <= f.max)) {
      std::ostringstream m;
      m << Where(name, f) << " = " << value.as<std::string>() << " is out of range [" << f.min
        << ", " << f.max << "]";
      return InvalidArgument(m.str());
    }
    if (auto* i = std::get_if<int*>(&f.target)) {
      const int as_int = value.as<int>();
      **i = as_int;
    } else {
      *std::get<double*>(f.target) = v;
    }
  } catch (const YAML::Exception&) {
    const char* want = std::holds_alternative<bool*>(f.target)  ? "true or false"
                       : std::holds_alternative<int*>(f.target) ? "an integer"
                                                                : "a number";
    return InvalidArgument(Where(name, f) + " must be " + want);
  }
  return Status::Ok();
}

Status Apply(const std::string& yaml, const std::string& name, const std::vector<Field>& fields) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml);
  } catch (const YAML::Exception& e) {
    return InvalidArgument(name + ": not valid YAML: " + e.what());
  }
  if (root.IsNull()) return Status::Ok();
  if (!root.IsMap()) return InvalidArgument(name + ": expected sections of key: value settings");
  for (const auto& section : root) {
    const std::string section_name = section.first.as<std::string>();
    bool known_section = false;
    for (const Field& f : fields) known_section |= f.section == section_name;
    if (!known_section) return InvalidArgument(name + ": unknown section '" + section_name + "'");
    if (!section.second.IsMap()) {
      return InvalidArgument(name + ": section '" + section_name + "' must hold key: value pairs");
    }
    for (const auto& entry : section.second) {
      const std::string key = entry.first.as<std::string>();
      const Field* field = nullptr;
      for (const Field& f : fields) {
        if (f.section == section_name && f.key == key) field = &f;
      }
      if (field == nullptr) {
        return InvalidArgument(name + ": unknown key '" + section_name + "." + key + "'");
      }
      SCENELOC_RETURN_IF_ERROR(SetField(*field, entry.second, name));
    }
  }
  return Status::Ok();
}

StatusOr<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return NotFound("settings file '" + path + "' cannot be opened");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string ToYaml(const std::vector<Field>& fields) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  std::string open;
  for (const Field& f : fields) {
    if (f.section != open) {
      if (!open.empty()) out << YAML::EndMap;
      out << YAML::Key << f.section << YAML::Value << YAML::BeginMap;
      open = f.section;
    }
    out << YAML::Key << f.key << YAML::Value;
    std::visit([&](auto* p) { out << *p; }, f.target);
  }
  if (!open.empty()) out << YAML::EndMap;
  out << YAML::EndMap;
  return out.c_str();
}

}  // namespace

Status ParseTrainOptions(const std::string& yaml, const std::string& name, TrainOptions* options) {
  TrainOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(Apply(yaml, name, TrainFields(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status ParseMatchOptions(const std::string& yaml, const std::string& name, MatchOptions* options) {
  MatchOptions updated = *options;
  SCENELOC_RETURN_IF_ERROR(Apply(yaml, name, MatchFields(&updated)));
  const Status valid = updated.Validate();
  if (!valid.ok()) return InvalidArgument(name + ": " + valid.message());
  *options = updated;
  return Status::Ok();
}

Status LoadTrainOptions(const std::string& path, TrainOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  return ParseTrainOptions(text, path, options);
}

Status LoadMatchOptions(const std::string& path, MatchOptions* options) {
  SCENELOC_ASSIGN_OR_RETURN(const std::string text, ReadFile(path));
  return ParseMatchOptions(text, path, options);
}

std::string TrainOptionsToYaml(const TrainOptions& options) {
  TrainOptions copy = options;
  return ToYaml(TrainFields(&copy));
}

std::string MatchOptionsToYaml(const MatchOptions& options) {
  MatchOptions copy = options;
  return ToYaml(MatchFields(&copy));
}

}  // namespace sceneloc
