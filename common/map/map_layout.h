// The payload layout of a map file (map_io.h), written down once as Transfer functions
// that a PayloadWriter (const fields) and a PayloadReader (mutable fields) both walk
// (payload_archive.h), for format version 2 and for version 1, which is still read.
// Keep it in step with the layout documented in map_io.h. Internal to map_io.
//
// Thread-safe: free functions without shared state.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "common/map/map.h"

namespace sceneloc::map_io_internal {

static_assert(std::numeric_limits<float>::is_iec559 && std::numeric_limits<double>::is_iec559);
static_assert(sizeof(int) == 4, "the format stores int fields as i32");
static_assert(std::is_trivially_copyable_v<PackedNeighbour> && sizeof(PackedNeighbour) == 12 &&
                  offsetof(PackedNeighbour, distance_mean) == 4 &&
                  offsetof(PackedNeighbour, cooccurrence) == 11,
              "PackedNeighbour is copied as the 12-byte record of map_io.h");

// A neighbour as format version 5 stores it (16 bytes): distances in units of the frame's
// long side / 32768, angles in pi / 32767 (mean), pi / 65535 (spread), pi / 255 (d_max).
struct PackedNeighbourV5 {
  uint32_t landmark = 0;
  uint16_t distance_mean = 0;
  uint16_t distance_sd = 0;
  uint16_t distance_dmax = 0;
  int16_t angle_mean = 0;
  uint16_t angle_sd = 0;
  uint8_t angle_dmax = 0;
  uint8_t cooccurrence = 0;
};
static_assert(std::is_trivially_copyable_v<PackedNeighbourV5> && sizeof(PackedNeighbourV5) == 16 &&
                  offsetof(PackedNeighbourV5, cooccurrence) == 15,
              "PackedNeighbourV5 is read as the 16-byte record of format version 5");
Neighbour UnpackV5(const PackedNeighbourV5& p, float frame);
PackedNeighbourV5 PackV5(const Neighbour& n, float frame);
static_assert(std::is_trivially_copyable_v<Neighbour> && sizeof(Neighbour) == 32 &&
                  offsetof(Neighbour, cooccurrence) == 4 && offsetof(Neighbour, angle_dmax) == 28,
              "Neighbour is read as the 32-byte record of format versions 1-4");
// A new option must be stored too: add it to TransferOptions, to the layout in
// map_io.h and to the round-trip test, bump kMapFormatVersion, then update these sizes.
static_assert(sizeof(void*) != 8 || sizeof(ExtractorOptions) == 80,
              "ExtractorOptions changed: update the map file format");
static_assert(sizeof(void*) != 8 || sizeof(TrainOptions) == 224,
              "TrainOptions changed: update the map file format");

// Fields of format version 1 that later versions store differently; read, then converted
// by UpgradeV1 once the map's frame is known.
struct V1Fields {
  double image_scale = 0;          // now: extractor.working_size
  double ransac_threshold_px = 0;  // now: ransac_threshold, a fraction of the frame
  double distance_var_floor = 0;   // now: distance_sd_floor, a fraction of the frame
};

// The payload layout, shared by writing (Archive = PayloadWriter, const fields) and
// reading (PayloadReader, mutable fields) of format `version` (a field a version lacks keeps
// its default, which is what the maps of that version were made with). Keep it in step with
// map_io.h. Writing always uses kMapFormatVersion.
template <typename Archive, typename Options, typename V1>
void TransferOptions(Archive& a, Options& o, uint32_t version, V1& v1) {
  const bool v2 = version >= 2;
  a.Field("extractor.max_features", o.extractor.max_features);
  if (v2) {
    a.Field("extractor.working_size", o.extractor.working_size);
  } else {
    a.Field("extractor.image_scale", v1.image_scale);
  }
  a.Field("extractor.context_scale", o.extractor.context_scale);
  a.Field("extractor.contrast_threshold", o.extractor.contrast_threshold);
  a.Field("extractor.edge_threshold", o.extractor.edge_threshold);
  a.Field("extractor.sigma", o.extractor.sigma);
  if (version >= 3) a.Field("extractor.octave_layers", o.extractor.octave_layers);
  a.Field("extractor.max_image_side", o.extractor.max_image_side);
  if (v2) {
    a.Field("extractor.clahe_clip", o.extractor.clahe_clip);
    a.Field("extractor.root_sift", o.extractor.root_sift);
    a.Field("extractor.holistic_cols", o.extractor.holistic.cols);
    a.Field("extractor.holistic_cell_pixels", o.extractor.holistic.cell_pixels);
    a.Field("extractor.holistic_bins", o.extractor.holistic.bins);
    a.Field("extractor.holistic_max_shift", o.extractor.holistic.max_shift);
  }
  a.Field("track_distance_threshold", o.track_distance_threshold);
  if (v2) {
    a.Field("ransac_threshold", o.ransac_threshold);
  } else {
    a.Field("ransac_threshold_px", v1.ransac_threshold_px);
  }
  a.Field("ransac_confidence", o.ransac_confidence);
  a.Field("min_links_per_pair", o.min_links_per_pair);
  a.Field("min_track_length", o.min_track_length);
  if (v2) a.Field("min_landmarks_per_image", o.min_landmarks_per_image);
  a.Field("local_var_floor", o.local_var_floor);
  a.Field("context_var_floor", o.context_var_floor);
  if (v2) {
    a.Field("distance_sd_floor", o.distance_sd_floor);
  } else {
    a.Field("distance_var_floor", v1.distance_var_floor);
  }
  a.Field("angle_var_floor", o.angle_var_floor);
  a.Field("quality_s_min", o.quality_s_min);
  a.Field("quality_fp_prior", o.quality_fp_prior);
  a.Field("eta", o.eta);
  a.Field("q_min", o.q_min);
  if (version >= 4) {
    a.Field("quality_window", o.quality_window);
  } else if constexpr (!std::is_const_v<Options>) {
    o.quality_window = 0;  // read from an older file: Q was measured over the whole tour
  }
  a.Field("max_neighbours", o.max_neighbours);
  if (version >= 4) {
    a.Field("place_index_min_locations", o.place_index_min_locations);
    if (version < 8) {
      int32_t place_index_dims = 0;  // the axes of versions 4-7's holistic projection
      a.Field("place_index_dims", place_index_dims);
    }
  } else if constexpr (!std::is_const_v<Options>) {
    o.place_index_min_locations = 0;  // read from an older file: made without one
  }
  if (v2) {
    a.Field("tolerance", o.tolerance);
    a.Field("confidence_temperature", o.confidence_temperature);
    a.Field("map_evidence_slope", o.map_evidence_slope);
    a.Field("map_evidence_offset", o.map_evidence_offset);
  }
}

template <typename Archive, typename Provenance>
void TransferProvenance(Archive& a, Provenance& p) {
  a.Field("provenance.tour_dir", p.tour_dir);
  a.Field("provenance.created_utc", p.created_utc);
  a.Field("provenance.tool_version", p.tool_version);
  a.Field("provenance.num_features", p.num_features);
  a.Field("provenance.num_tracks", p.num_tracks);
  a.Field("provenance.num_candidates", p.num_candidates);
}

template <typename Archive, typename CalibrationT>
void TransferCalibration(Archive& a, CalibrationT& c) {
  a.Field("calibration.valid", c.valid);
  a.Field("calibration.off_map_distance", c.off_map_distance);
  a.Field("calibration.off_map_spread", c.off_map_spread);
  a.Field("calibration.samples", c.samples);
}

template <typename Archive, typename Index>
void TransferPlaceIndex(Archive& a, Index& p, uint32_t version) {
  a.Field("place_index.coarse", p.vocabulary.coarse);
  a.Field("place_index.fine", p.vocabulary.fine);
  a.Field("place_index.centroids", p.vocabulary.centroids);
  a.Field("place_index.landmark_word", p.landmark_word);
  if (version >= 8) {
    a.Field("place_index.holistic_bins", p.holistic.bins);
    a.Field("place_index.holistic_codebook", p.holistic.codebook);
    a.Field("place_index.holistic_codes", p.holistic.codes);
    return;
  }
  // Versions 4-7 projected the holistic descriptors on principal axes instead: read past
  // (written empty); Map::Finalize codes the descriptors.
  int32_t max_shift = 0, dims = 0;
  std::vector<float> mean, axes, projected, residual;
  a.Field("place_index.holistic_max_shift", max_shift);
  a.Field("place_index.holistic_dims", dims);
  a.Field("place_index.holistic_mean", mean);
  a.Field("place_index.holistic_axes", axes);
  a.Field("place_index.holistic_projected", projected);
  a.Field("place_index.holistic_residual", residual);
}

// The fields format version 5 stores compactly (compact.h) and older versions as floats:
// an older version is written from, and read into, floats converted to and from the map's
// compact fields (the map keeps what today's version would).
template <typename Archive, typename Bytes>
void UnitBytes(Archive& a, const char* name, uint32_t version, Bytes& bytes) {
  if (version >= 5) {
    a.Field(name, bytes);
  } else if constexpr (std::is_const_v<Bytes>) {
    std::vector<float> values(bytes.size());
    for (size_t i = 0; i < bytes.size(); ++i) values[i] = UnitValue(bytes[i]);
    a.Field(name, values);
  } else {
    std::vector<float> values;
    a.Field(name, values);
    bytes.resize(values.size());
    for (size_t i = 0; i < values.size(); ++i) bytes[i] = UnitByte(values[i]);
  }
}

template <typename Archive, typename Matrix>
void DescriptorRows(Archive& a, const char* name, uint32_t version, Matrix& bytes) {
  if (version >= 5) {
    a.Field(name, bytes);
  } else if constexpr (std::is_const_v<Matrix>) {
    const DescriptorMatrix values = bytes.template cast<float>() * (1.0f / 255.0f);
    a.Field(name, values);
  } else {
    DescriptorMatrix values;
    a.Field(name, values);
    bytes.resize(values.rows(), kDescriptorSize);
    for (Eigen::Index i = 0; i < values.size(); ++i) bytes.data()[i] = UnitByte(values.data()[i]);
  }
}

// The context spreads: version 6 stores their codes (ContextSpreadCode), version 5 binary16
// values, older versions f32. `positive`: a code is at least 1 (a variance).
template <typename Archive, typename Matrix>
void HistogramRows(Archive& a, const char* name, uint32_t version, bool positive, Matrix& codes) {
  if (version >= 6) {
    a.Field(name, codes);
    return;
  }
  const LogCode& code = ContextSpreadCode();
  const auto transfer = [&](auto value_type) {
    using T = decltype(value_type);
    using Values = Eigen::Matrix<T, Eigen::Dynamic, kNumHistograms, Eigen::RowMajor>;
    const auto to_value = [](float v) {
      if constexpr (std::is_same_v<T, float>)
        return v;
      else
        return HalfBits(v);
    };
    const auto from_value = [](T v) {
      if constexpr (std::is_same_v<T, float>)
        return v;
      else
        return HalfValue(v);
    };
    if constexpr (std::is_const_v<Matrix>) {
      Values values(codes.rows(), kNumHistograms);
      for (Eigen::Index i = 0; i < values.size(); ++i)
        values.data()[i] = to_value(code.Decode(codes.data()[i]));
      a.Field(name, values);
    } else {
      Values values;
      a.Field(name, values);
      codes.resize(values.rows(), kNumHistograms);
      for (Eigen::Index i = 0; i < values.size(); ++i) {
        const uint8_t c = code.Encode(from_value(values.data()[i]));
        codes.data()[i] = positive ? std::max<uint8_t>(c, 1) : c;
      }
    }
  };
  if (version == 5) {
    transfer(uint16_t{});
  } else {
    transfer(float{});
  }
}

template <typename Archive, typename MapT>
void Neighbours(Archive& a, uint32_t version, MapT& m) {
  const auto frame = static_cast<float>(std::max(m.image_width, m.image_height));
  if (version >= 6) {
    a.Field("neighbours", m.neighbours);
  } else if (version == 5) {
    std::vector<PackedNeighbourV5> values;
    if constexpr (std::is_const_v<MapT>) {
      for (const PackedNeighbour& p : m.neighbours)
        values.push_back(PackV5(Unpack(p, frame), frame));
      a.Field("neighbours", values);
    } else {
      a.Field("neighbours", values);
      m.neighbours.resize(values.size());
      for (size_t i = 0; i < values.size(); ++i)
        m.neighbours[i] = Pack(UnpackV5(values[i], frame), frame);
    }
  } else if constexpr (std::is_const_v<MapT>) {
    std::vector<Neighbour> values;
    for (const PackedNeighbour& p : m.neighbours) values.push_back(Unpack(p, frame));
    a.Field("neighbours", values);
  } else {
    std::vector<Neighbour> values;
    a.Field("neighbours", values);
    m.neighbours.resize(values.size());
    for (size_t i = 0; i < values.size(); ++i) m.neighbours[i] = Pack(values[i], frame);
  }
}

// Where the landmarks were seen: version 6 stores them packed (compact.h
// PackedObservation) with a flag for whether the orientations are known; older versions
// store f32 arrays of x, y and size, and from version 2 of the angle (version 1 has none).
template <typename Archive, typename MapT>
void Observations(Archive& a, uint32_t version, MapT& m) {
  if (version >= 6) {
    a.Field("observations", m.observations);
    a.Field("observation_angles", m.observation_angles);
    return;
  }
  std::vector<float> x, y, size, angle;
  if constexpr (std::is_const_v<MapT>) {
    for (const PackedObservation& o : m.observations) {
      x.push_back(o.X());
      y.push_back(o.Y());
      size.push_back(o.Size());
      angle.push_back(o.Angle());
    }
  }
  a.Field("observation_x", x);
  a.Field("observation_y", y);
  a.Field("observation_size", size);
  if (version >= 2) a.Field("observation_angle", angle);
  if constexpr (!std::is_const_v<MapT>) {
    // Arrays of different lengths leave the observations short, for Validate to report.
    size_t n = std::min({x.size(), y.size(), size.size()});
    if (version >= 2) n = std::min(n, angle.size());
    m.observations.resize(n);
    for (size_t i = 0; i < n; ++i) {
      m.observations[i] = PackObservation(x[i], y[i], size[i], version >= 2 ? angle[i] : 0);
    }
    m.observation_angles = version >= 2;
  }
}

// The experiences (format version 9) as parallel arrays, one entry per experience.
template <typename Archive, typename MapT>
void TransferExperiences(Archive& a, MapT& m) {
  std::vector<std::string> name, source, created;
  std::vector<uint32_t> kind, first, count, frames, samples;
  std::vector<float> level, spread;
  if constexpr (std::is_const_v<MapT>) {
    for (const Experience& e : m.experiences) {
      name.push_back(e.name);
      source.push_back(e.source_dir);
      created.push_back(e.created_utc);
      kind.push_back(static_cast<uint32_t>(e.kind));
      first.push_back(e.first_image);
      count.push_back(e.num_images);
      frames.push_back(e.walk_frames);
      samples.push_back(e.calibration.valid ? e.calibration.samples : 0);
      level.push_back(e.calibration.off_map_distance);
      spread.push_back(e.calibration.off_map_spread);
    }
  }
  a.Field("experience_name", name);
  a.Field("experience_source", source);
  a.Field("experience_created", created);
  a.Field("experience_kind", kind);
  a.Field("experience_first_image", first);
  a.Field("experience_images", count);
  a.Field("experience_walk_frames", frames);
  a.Field("experience_calibration_samples", samples);
  a.Field("experience_off_map_distance", level);
  a.Field("experience_off_map_spread", spread);
  if constexpr (!std::is_const_v<MapT>) {
    const size_t n = name.size();
    for (const size_t size :
         {source.size(), created.size(), kind.size(), first.size(), count.size(), frames.size(),
          samples.size(), level.size(), spread.size()}) {
      if (size != n) {
        a.Fail("the experiences' arrays differ in length");
        return;
      }
    }
    m.experiences.clear();
    for (size_t i = 0; i < n; ++i) {
      Calibration c;
      c.valid = samples[i] > 0;
      c.samples = samples[i];
      c.off_map_distance = level[i];
      c.off_map_spread = spread[i];
      m.experiences.push_back({name[i], source[i], created[i], static_cast<ExperienceKind>(kind[i]),
                               first[i], count[i], frames[i], c});
    }
  }
}

template <typename Archive, typename MapT, typename V1>
void TransferMap(Archive& a, MapT& m, uint32_t version, V1& v1) {
  TransferOptions(a, m.options, version, v1);
  TransferProvenance(a, m.provenance);
  if (version >= 2) TransferCalibration(a, m.calibration);
  a.Field("image_names", m.image_names);
  a.Field("image_width", m.image_width);
  a.Field("image_height", m.image_height);
  if (version >= 2) {
    a.Field("holistic_grid.cols", m.holistic_grid.cols);
    a.Field("holistic_grid.rows", m.holistic_grid.rows);
    a.Field("holistic_grid.bins", m.holistic_grid.bins);
    UnitBytes(a, "holistic", version, m.holistic);
  }
  DescriptorRows(a, "local_mean", version, m.local_mean);
  a.Field("local_dmax", m.local_dmax);
  a.Field("local_var", m.local_var);
  DescriptorRows(a, "context_mean", version, m.context_mean);
  HistogramRows(a, "context_dmax", version, false, m.context_dmax);
  HistogramRows(a, "context_var", version, true, m.context_var);
  if (version >= 6) {
    a.Field("quality", m.quality);
    a.Field("observation_offsets", m.observation_offsets);
    a.Field("observation_image", m.observation_image);
    Observations(a, version, m);
  } else {
    // Older versions store each landmark's mean position, which today's maps compute from
    // the observations (Map::MeanPosition): read and left, or written from them.
    std::vector<float> mean_x, mean_y;
    if constexpr (std::is_const_v<MapT>) {
      for (int g = 0; g < m.num_landmarks(); ++g) {
        const auto [x, y] = m.MeanPosition(g);
        mean_x.push_back(x);
        mean_y.push_back(y);
      }
    }
    a.Field("mean_x", mean_x);
    a.Field("mean_y", mean_y);
    a.Field("quality", m.quality);
    a.Field("observation_offsets", m.observation_offsets);
    a.Field("observation_image", m.observation_image);
    Observations(a, version, m);
  }
  a.Field("neighbour_offsets", m.neighbour_offsets);
  Neighbours(a, version, m);
  a.Field("image_offsets", m.image_offsets);
  a.Field("image_landmarks", m.image_landmarks);
  if (version >= 4) TransferPlaceIndex(a, m.place_index, version);
  if (version >= 7) {
    a.Field("lookalike_offsets", m.lookalike_offsets);
    a.Field("lookalike_location", m.lookalike_location);
    a.Field("lookalike_ratio", m.lookalike_ratio);
  }
  if (version >= 9) {
    a.Field("image_place", m.image_place);
    TransferExperiences(a, m);
  }
}

// A version-1 map in today's terms: its working frame is the frame it was made in, its
// pixel settings become fractions of that frame, and it has no holistic descriptors and
// no coverage rule. Leaves a settings error for Validate() to report.
void UpgradeV1(const V1Fields& v1, Map* map);

}  // namespace sceneloc::map_io_internal
