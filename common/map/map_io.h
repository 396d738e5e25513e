// Map files: the binary form of a Map, written atomically and read back with every byte
// checked. A map file comes from disk or the network, so it is untrusted input: no byte
// sequence makes LoadMap or ParseMap crash, read out of bounds or allocate much more
// than the file's own size; each failure is a status whose message names the file.
//
// Layout, format version 9. Integers are little-endian two's complement, f32/f64 are
// IEEE 754 binary32/binary64 little-endian. There is no padding anywhere.
//
//   Header, 32 bytes:
//     offset  0  char[8]  magic           "SCNLMAP\0"
//     offset  8  u32      format_version  kMapFormatVersion
//     offset 12  u32      flags           0 (none defined; a reader refuses others)
//     offset 16  u64      payload_bytes   size of the payload; the file ends with it
//     offset 24  u32      payload_crc     CRC-32 (IEEE, crc32.h) of the payload
//     offset 28  u32      header_crc      CRC-32 of header bytes 0..27
//   Payload, in this order:
//     TrainOptions   extractor: i32 max_features, i32 working_size, f64 context_scale,
//                      f64 contrast_threshold, f64 edge_threshold, f64 sigma,
//                      i32 octave_layers, i32 max_image_side, f64 clahe_clip, u8 root_sift,
//                      i32 holistic_cols, i32 holistic_cell_pixels, i32 holistic_bins,
//                      i32 holistic_max_shift;
//                    f64 track_distance_threshold, f64 ransac_threshold,
//                    f64 ransac_confidence, i32 min_links_per_pair, i32 min_track_length,
//                    i32 min_landmarks_per_image, f64 local_var_floor,
//                    f64 context_var_floor, f64 distance_sd_floor, f64 angle_var_floor,
//                    f64 quality_s_min, f64 quality_fp_prior, i32 eta, f64 q_min,
//                    i32 quality_window, i32 max_neighbours,
//                    i32 place_index_min_locations
//                    i32 tolerance, f64 confidence_temperature, f64 map_evidence_slope,
//                    f64 map_evidence_offset
//     MapProvenance  str tour_dir, str created_utc, str tool_version, u32 num_features,
//                    u32 num_tracks, u32 num_candidates
//     Calibration    u8 valid, f32 off_map_distance, f32 off_map_spread, u32 samples
//     Images         u64 N, N x str image_names; i32 image_width, i32 image_height;
//                    i32 holistic cols, i32 rows, i32 bins, arr<u8> holistic
//                    (N x cols x rows x bins unit bytes, or empty with a zero grid)
//     Landmarks      mat<u8> local_mean (128 cols, unit bytes), arr<f32> local_dmax,
//                    arr<f32> local_var, mat<u8> context_mean (128),
//                    mat<u8> context_dmax (16), mat<u8> context_var (16) (log codes),
//                    arr<f32> quality
//     Observations   arr<u32> observation_offsets, arr<u32> observation_image,
//                    arr<observation> observations, u8 observation_angles (flag: the
//                    orientations are known)
//     Neighbours     arr<u32> neighbour_offsets, arr<neighbour> neighbours
//     Image lists    arr<u32> image_offsets, arr<u32> image_landmarks
//     Place index    i32 coarse, i32 fine, mat centroids (128 cols), arr<u32> landmark_word,
//                    i32 holistic_bins, arr<f32> holistic_codebook (256 x bins),
//                    arr<u8> holistic_codes (N x cols x rows) (all zero or empty in a map
//                    without one; place_index.h)
//     Look-alikes    arr<u32> lookalike_offsets, arr<u32> lookalike_location,
//                    arr<f32> lookalike_ratio (all empty in a map without them; map.h)
//                    (version 7; versions 1-6 end before them)
//     Places         arr<u32> image_place (the place each image shows; empty: image i is
//                    place i)
//     Experiences    arr<str> experience_name, arr<str> experience_source, arr<str>
//                    experience_created, arr<u32> experience_kind (0 tour, 1 route, 2 new
//                    ground), arr<u32> experience_first_image, arr<u32> experience_images,
//                    arr<u32> experience_walk_frames, arr<u32>
//                    experience_calibration_samples (0: none), arr<f32>
//                    experience_off_map_distance, arr<f32> experience_off_map_spread: one
//                    entry each per walk, in image order (map.h Experience)
//   where  str       = u64 byte count, then the bytes (UTF-8, no terminator)
//          arr<T>    = u64 element count, then the elements packed
//          mat<T>    = u64 rows, u64 cols (must equal the stated count), rows x cols T
//                      row-major (mat = mat<f32>)
//          unit byte = a value in [0, 1] as round(255 x) (compact.h)
//          log code  = a byte, 0 for 0 and 1..255 for low (high / low)^((c - 1) / 254)
//                      (compact.h LogCode): context spreads low 1e-6, high 4
//          observation = 8 bytes (compact.h PackedObservation): u16 x, u16 y (1/16
//                      pixel), u16 size (f16, pixels), u16 angle (360 / 65536 degrees)
//          neighbour = 12 bytes (compact.h PackedNeighbour): u32 landmark, u16
//                      distance_mean (units of the frame's long side / 32768), u8
//                      distance_sd, u8 distance_dmax (log codes of fractions of the long
//                      side, low 1/32768, high 2), i8 angle_mean (pi / 128), u8 angle_sd
//                      (log code of radians, low pi / 65536, high pi), u8 angle_dmax
//                      (pi / 255), u8 cooccurrence (1 / 255)
//
//   where a u8 flag is 0 or 1.
//
//   Format version 8 (still read): as 9 without the places and experiences (one walk, one
//   image per place).
//   Format version 7 (still read): as 8 with i32 place_index_dims after
//   place_index_min_locations and the place index's holistic part as i32 holistic_max_shift,
//   i32 holistic_dims, arr<f32> holistic_mean, arr<f32> holistic_axes, arr<f32>
//   holistic_projected, arr<f32> holistic_residual (principal axes of the holistic
//   descriptors per lateral shift and every location's projection on them): a reader reads
//   past them, and loading codes the holistic descriptors as version 8 stores them. Format
//   version 6 (still read): as 7 without the look-alikes.
//   Format version 5 (still read): as 6 with arr<f32> mean_x, arr<f32> mean_y (each
//   landmark's mean position, which today's maps compute) before quality, the observations as
//   arr<f32> observation_x, arr<f32> observation_y, arr<f32> observation_size, arr<f32>
//   observation_angle (no flag: known), the context spreads as mat<f16> (IEEE binary16) and each
//   neighbour as 16 bytes (u32 landmark, u16 distance_mean, u16 distance_sd, u16 distance_dmax in
//   units of the long side / 32768, i16 angle_mean in pi / 32767, u16 angle_sd in pi / 65535, u8
//   angle_dmax in pi / 255, u8 cooccurrence in 1 / 255); a reader codes them as version 6 stores
//   them.
//
//   Format version 4 (still read): as 5 with the holistic descriptors, the mean descriptors
//   and the context spreads as f32 (mat, arr<f32>) and each neighbour as 32 bytes (u32
//   landmark, then f32 cooccurrence, distance_mean, distance_var, distance_dmax, angle_mean,
//   angle_var, angle_dmax); a reader compacts them as version 5 stores them.
//   Format version 3 (still read): as 4 without quality_window (those maps measured Q over
//   the whole tour: they load with a window of 0) and without the place index (they are
//   searched whole).
//   Format version 2 (still read): as 3 without extractor.octave_layers (those maps were
//   all made with 3 layers, OpenCV's default, which a version 2 map loads with).
//   Format version 1 (still read): extractor.working_size was f64 image_scale, and the
//   lighting, holistic, confidence and calibration fields, min_landmarks_per_image and
//   observation_angle were absent;
//   ransac_threshold was f64 ransac_threshold_px and distance_sd_floor f64
//   distance_var_floor (pixels^2). LoadMap converts such a map to today's terms: its
//   working frame is the frame it was made in, pixel settings become fractions of it, and
//   it has neither holistic descriptors nor a calibration (see UpgradeV1 in map_layout.cc).
//   The derived Map fields (local_mean_sqnorm) are not stored; loading recomputes them.
//
// Compatibility: bytes 0..11 (magic and format version) mean the same in every version;
// everything after them may change with the version. Any change to the layout above
// bumps kMapFormatVersion; every older version stays readable. A reader refuses files of
// a newer version (Unimplemented) rather than guess at them.
//
// Thread-safe: these are free functions without shared state. Two concurrent SaveMap
// calls for the same path from one process share a temporary file name and must not
// overlap; different paths, or different processes, are fine.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "common/map/map.h"
#include "common/util/status.h"

namespace sceneloc {

inline constexpr char kMapMagic[8] = {'S', 'C', 'N', 'L', 'M', 'A', 'P', '\0'};
inline constexpr uint32_t kMapFormatVersion = 9;
inline constexpr size_t kMapHeaderBytes = 32;

// What the header of a map file says.
struct MapFileInfo {
  uint32_t format_version = 0;
  uint64_t payload_bytes = 0;
  // CRC-32 of the payload: identifies the map's content (the same map serialised twice
  // gives the same checksum), so a server can report which map it serves.
  uint32_t checksum = 0;
};

// Writes `map` to `path` so that `path` holds either its old content or the whole new
// file, never part of one: the bytes go to `path + ".tmp.<pid>"` in the same folder,
// which is fsynced, renamed over `path`, and the folder fsynced. On failure the
// temporary file is removed and the status (IoError) names the path and the OS error.
// A map that fails Validate() is refused (InvalidArgument) and nothing is written.
// On success, fills *info when info is not null.
Status SaveMap(const Map& map, const std::string& path, MapFileInfo* info = nullptr);

// The largest map file LoadMap reads by default: 4 GiB (a 20,000-location map is about
// 0.7 GB; a 200-location one 7 MB).
inline constexpr uint64_t kDefaultMaxMapBytes = uint64_t{4} << 30;

struct MapLoadOptions {
  uint64_t max_file_bytes = kDefaultMaxMapBytes;  // larger files are refused unread
};

// Reads, checks, validates and finalises the map file at `path`. A map file is untrusted
// input: the 32-byte header and the sizes it declares are checked against the file and
// `options` before any of the payload is read, and the payload is parsed as it is read
// (every declared count checked against what is left before anything is allocated), so
// memory never exceeds the map itself plus 128 KiB, and a file that shrinks while it is
// read is an error, not a crash. Errors name the file: NotFound (no such file), IoError
// (cannot be read, not a regular file), InvalidArgument (not a map file), Unimplemented
// (newer format version or unknown header flags), ResourceExhausted (larger than
// options.max_file_bytes, with both sizes), DataLoss (empty, truncated, checksum
// mismatch, malformed payload, or a map that fails Validate()). On success, fills *info
// when info is not null.
StatusOr<Map> LoadMap(const std::string& path, MapFileInfo* info = nullptr,
                      const MapLoadOptions& options = MapLoadOptions());

// LoadMap's work on bytes already in memory (e.g. a map received by the server).
// `name_for_errors` stands in for the path in error messages.
StatusOr<Map> ParseMap(const std::string& bytes, const std::string& name_for_errors,
                       MapFileInfo* info = nullptr);

// The whole file, header and payload, that SaveMap would write for `map`. Does not
// validate `map`, so tests can build files holding maps that are well-formed but
// inconsistent.
std::string SerializeMap(const Map& map);

}  // namespace sceneloc
