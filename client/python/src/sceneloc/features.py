"""A frame's features, for the thin-client path: a robot extracts them itself (or with
`sceneloc extract`) and sends them instead of a JPEG (LocaliseRequest.features).

What the server expects (proto FeatureSet, common/features/feature_set.h): keypoints in the
frame of `image_width` x `image_height` pixels (best the map's own working frame: `sceneloc
extract --map-file` uses it; another width is rescaled on the server), and per keypoint two
SIFT descriptors of 128 values, `local` at the keypoint's size and `context` at the same
point and angle at twice the size, from the same extractor settings as the map. Optionally
the frame's holistic descriptor on the map's grid (without it the server localises from the
keypoints alone, weaker at night and in low texture).
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional, Union

import numpy as np
from google.protobuf.message import DecodeError

from .wire import field_head, length_delimited, pb

DESCRIPTOR_SIZE = 128
# Largest distance of a float32 descriptor's norm from 1 the server accepts (proto/wire.cc).
NORM_TOLERANCE = 0.01
# The holistic grid sizes the server accepts (proto/wire.cc DecodeHolistic).
_MAX_HOLISTIC_COLS, _MAX_HOLISTIC_ROWS, _MAX_HOLISTIC_BINS = 64, 256, 36


def _positive_int(value: object, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
        raise ValueError(f"{what} must be a positive integer, not {value!r}")
    return int(value)


def _vector(values: object, dtype: type, what: str) -> np.ndarray:
    array = np.ascontiguousarray(values, dtype=dtype)
    if array.ndim != 1:
        raise ValueError(f"{what} must be a 1-D array, not of shape {array.shape}")
    return array


def _descriptors(values: object, n: int, which: str) -> np.ndarray:
    """`values` as an n x 128 float32 matrix of unit (or zero) rows, or as uint8 rows."""
    array = np.asarray(values)
    if array.ndim != 2 or array.shape[1] != DESCRIPTOR_SIZE or array.shape[0] != n:
        raise ValueError(
            f"{which} descriptors must be {n} x {DESCRIPTOR_SIZE} (one row per keypoint), "
            f"not of shape {array.shape}"
        )
    if array.dtype == np.uint8:  # any scale: the server L2-normalises each row
        return np.ascontiguousarray(array)
    if not np.issubdtype(array.dtype, np.floating):
        raise ValueError(
            f"{which} descriptors must be float32 (L2-normalised rows) or uint8, not {array.dtype}"
        )
    array = np.ascontiguousarray(array, dtype=np.float32)
    if not np.isfinite(array).all():
        raise ValueError(f"{which} descriptors hold a non-finite number")
    norms = np.linalg.norm(array, axis=1)
    bad = np.flatnonzero((norms != 0) & (np.abs(norms - 1) > NORM_TOLERANCE))
    if bad.size:
        raise ValueError(
            f"{which} descriptor {bad[0]} has norm {norms[bad[0]]:.4f}; float descriptors must "
            "be L2-normalised rows (divide each by its norm, or send them as uint8)"
        )
    return array


def _quantise(descriptors: np.ndarray) -> np.ndarray:
    """uint8 descriptors as the C++ client makes them: round(512 v) clamped to [0, 255]."""
    if descriptors.dtype == np.uint8:
        return descriptors
    scaled = np.float32(512) * descriptors
    floor = np.floor(scaled)
    rounded = floor + (scaled - floor >= 0.5)  # half away from zero, as std::round
    return np.clip(rounded, 0, 255).astype(np.uint8)


def _matrix_parts(field: int, descriptors: np.ndarray) -> list:
    """FeatureSet's `field` (a pb.DescriptorMatrix) as parts to join: the keys and lengths,
    then the array's own memory as its uint8 field (2), or its float32 field (1) as one
    packed run of little-endian floats."""
    if descriptors.dtype == np.uint8:
        inner, values = 2, descriptors
    else:
        inner, values = 1, descriptors.astype("<f4", copy=False)
    values = np.ascontiguousarray(values)
    head = field_head(inner, values.nbytes)
    return [field_head(field, len(head) + values.nbytes), head, memoryview(values).cast("B")]


# The keypoints' wire bytes, one row per keypoint: FeatureSet field 3's key and length, then
# Keypoint fields 1-5 (fixed32 floats: key, 4 bytes) and 6 (the octave: key, varint of up
# to 10 bytes, as protobuf writes a negative int32).
_KEYPOINT_FLOAT_KEYS = (0x0D, 0x15, 0x1D, 0x25, 0x2D)  # field << 3 | 5 for fields 1-5
_KEYPOINT_OCTAVE_KEY = 0x30  # field 6 << 3 | 0
_KEYPOINTS_KEY = 0x1A  # FeatureSet field 3 << 3 | 2
_VARINT_MAX = 10


def _keypoints_bytes(floats: np.ndarray, octave: np.ndarray) -> bytes:
    """FeatureSet's repeated field 3 for n keypoints, byte for byte as protobuf serialises
    it: n x 5 floats (x, y, size, angle, response) and n octaves. Proto3 leaves out a float
    whose bits are all zero and a zero octave; every Keypoint is at most 36 bytes, so its
    length is one byte. Built as one n x 38 byte matrix and a mask of the bytes present, so a
    thousand keypoints take a fraction of a millisecond rather than a protobuf object each."""
    n = floats.shape[0]
    rows = np.zeros((n, 2 + 5 * 5 + 1 + _VARINT_MAX), dtype=np.uint8)
    present = np.zeros(rows.shape, dtype=bool)
    values = np.ascontiguousarray(floats, dtype="<f4")
    value_bytes = values.view(np.uint8).reshape(n, 5, 4)
    has_float = values.view("<u4") != 0
    for f, key in enumerate(_KEYPOINT_FLOAT_KEYS):
        at = 2 + 5 * f
        rows[:, at] = key
        rows[:, at + 1:at + 5] = value_bytes[:, f, :]
        present[:, at:at + 5] = has_float[:, f:f + 1]
    # The octave as protobuf's varint of the int32 sign-extended to 64 bits.
    at = 2 + 5 * 5
    wide = octave.astype(np.int64).view(np.uint64)
    groups = np.stack([(wide >> np.uint64(7 * i)) & np.uint64(0x7F) for i in range(_VARINT_MAX)],
                      axis=1).astype(np.uint8)
    nonzero = groups != 0
    length = np.where(nonzero.any(axis=1), _VARINT_MAX - np.argmax(nonzero[:, ::-1], axis=1), 1)
    index = np.arange(_VARINT_MAX)
    groups |= np.where(index < (length - 1)[:, None], 0x80, 0).astype(np.uint8)
    has_octave = octave != 0
    rows[:, at] = _KEYPOINT_OCTAVE_KEY
    rows[:, at + 1:] = groups
    present[:, at] = has_octave
    present[:, at + 1:] = has_octave[:, None] & (index < length[:, None])
    rows[:, 0] = _KEYPOINTS_KEY
    rows[:, 1] = present[:, 2:].sum(axis=1)
    present[:, :2] = True
    return rows[present].tobytes()


def _decode_matrix(wire: pb.DescriptorMatrix, n: int, which: str) -> np.ndarray:
    floats, raw = len(wire.float32), len(wire.uint8)
    if floats and raw:
        raise ValueError(f"{which} descriptors are set as both float32 and uint8")
    if (floats or raw) != n * DESCRIPTOR_SIZE:
        raise ValueError(
            f"{which} descriptors hold {floats or raw} values; {n} keypoints need "
            f"{n * DESCRIPTOR_SIZE} ({DESCRIPTOR_SIZE} each)"
        )
    if raw:
        return np.frombuffer(wire.uint8, dtype=np.uint8).reshape(n, DESCRIPTOR_SIZE)
    values = np.fromiter(wire.float32, dtype=np.float32, count=floats)
    return values.reshape(n, DESCRIPTOR_SIZE)


@dataclasses.dataclass(frozen=True, eq=False)
class Holistic:
    """The frame's holistic descriptor: rows x cols cells of `bins` values, each in [0, 1]
    (common/features/holistic.h). Its grid must be the map's."""

    cols: int
    rows: int
    bins: int
    values: np.ndarray  # float32, rows x cols x bins values, cell after cell

    def __post_init__(self) -> None:
        for name, limit in (
            ("cols", _MAX_HOLISTIC_COLS), ("rows", _MAX_HOLISTIC_ROWS), ("bins", _MAX_HOLISTIC_BINS)
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not (
                1 <= value <= limit
            ):
                raise ValueError(
                    f"holistic {name} must be an integer in [1, {limit}], not {value!r}"
                )
            object.__setattr__(self, name, int(value))  # frozen to its users
        values = _vector(np.ravel(self.values), np.float32, "holistic values")
        if values.size != self.cols * self.rows * self.bins:
            raise ValueError(
                f"holistic descriptor holds {values.size} values; its grid "
                f"{self.cols}x{self.rows}x{self.bins} needs {self.cols * self.rows * self.bins}"
            )
        if not ((values >= 0) & (values <= 1)).all():
            raise ValueError("holistic descriptor holds a value outside [0, 1]")
        object.__setattr__(self, "values", values)


@dataclasses.dataclass(frozen=True, eq=False)
class FeatureSet:
    """One frame's features, checked when made (ValueError saying what is wrong).

    Keypoint i is (x[i], y[i], size[i], angle[i], response[i], octave[i]) and is described by
    row i of `local` and of `context`. Arrays are converted to the types below; one already
    of its type is used as given, not copied.
    """

    image_width: int  # the frame the keypoints are in, pixels
    image_height: int
    x: np.ndarray  # float32, pixels
    y: np.ndarray  # float32, pixels
    size: np.ndarray  # float32, SIFT diameter, pixels
    angle: np.ndarray  # float32, degrees in [0, 360)
    response: np.ndarray  # float32, detector response
    octave: np.ndarray  # int32, OpenCV's packed octave
    # N x 128: float32 rows of norm 1 (or 0), as the extractor makes them; or uint8 rows at
    # any scale (e.g. OpenCV's 0..255 SIFT), which the server L2-normalises.
    local: np.ndarray  # standard SIFT at the keypoint's size
    context: np.ndarray  # SIFT at the same point and angle, twice the size
    holistic: Optional[Holistic] = None

    def __post_init__(self) -> None:
        self._set("image_width", _positive_int(self.image_width, "image_width"))
        self._set("image_height", _positive_int(self.image_height, "image_height"))
        for name in ("x", "y", "size", "angle", "response"):
            self._set(name, _vector(getattr(self, name), np.float32, f"keypoint {name}"))
        self._set("octave", _vector(self.octave, np.int32, "keypoint octave"))
        n = self.x.size
        for name in ("y", "size", "angle", "response", "octave"):
            if getattr(self, name).size != n:
                raise ValueError(
                    f"keypoint {name} holds {getattr(self, name).size} values; x holds {n}"
                )
        for name in ("x", "y", "size", "angle"):  # the server refuses non-finite ones
            if not np.isfinite(getattr(self, name)).all():
                raise ValueError(f"keypoint {name} holds a non-finite number")
        self._set("local", _descriptors(self.local, n, "local"))
        self._set("context", _descriptors(self.context, n, "context"))
        if self.holistic is not None and not isinstance(self.holistic, Holistic):
            raise TypeError(
                f"holistic must be a sceneloc.Holistic or None, not {type(self.holistic).__name__}"
            )

    def _set(self, name: str, value: object) -> None:
        object.__setattr__(self, name, value)  # the dataclass is frozen to its users

    def __len__(self) -> int:
        """The number of keypoints."""
        return int(self.x.size)

    def as_uint8(self) -> FeatureSet:
        """This feature set with uint8 descriptors (a quarter of the bytes on the wire, ~0.2%
        of a descriptor's norm lost to rounding), quantised as the C++ client does."""
        return dataclasses.replace(
            self, local=_quantise(self.local), context=_quantise(self.context)
        )

    def to_bytes(self) -> bytes:
        """The serialised wire message, byte for byte what to_proto().SerializeToString()
        gives (fields in number order), made with numpy from the keypoints' and the
        descriptors' bytes rather than value by value (descriptors travel as they are held:
        float32 or uint8)."""
        return b"".join(self._wire_parts())

    def _wire_parts(self) -> list:
        """to_bytes() as parts to join (bytes and views of the descriptor arrays), so that a
        caller joins them once with what goes before them (Client.localise_features)."""
        head = pb.FeatureSet(image_width=self.image_width, image_height=self.image_height)
        parts = [head.SerializeToString()]
        if len(self):
            floats = np.stack([self.x, self.y, self.size, self.angle, self.response], axis=1)
            parts.append(_keypoints_bytes(floats, self.octave))
            parts += _matrix_parts(4, self.local)
            parts += _matrix_parts(5, self.context)
        if self.holistic is not None:
            h = self.holistic
            holistic = pb.Holistic(cols=h.cols, rows=h.rows, bins=h.bins).SerializeToString()
            if h.values.size:
                holistic += length_delimited(4, h.values.astype("<f4", copy=False).tobytes())
            parts.append(length_delimited(6, holistic))
        return parts

    def to_proto(self) -> pb.FeatureSet:
        """The wire message (descriptors travel as they are held: float32 or uint8)."""
        return pb.FeatureSet.FromString(self.to_bytes())

    @classmethod
    def from_proto(cls, wire: pb.FeatureSet) -> FeatureSet:
        """Reads a wire message, checking it as the server would (ValueError)."""
        n = len(wire.keypoints)
        k = wire.keypoints
        h = wire.holistic
        has_holistic = bool(h.cols or h.rows or h.bins or len(h.values))
        return cls(
            image_width=wire.image_width,
            image_height=wire.image_height,
            x=np.fromiter((p.x for p in k), np.float32, n),
            y=np.fromiter((p.y for p in k), np.float32, n),
            size=np.fromiter((p.size for p in k), np.float32, n),
            angle=np.fromiter((p.angle for p in k), np.float32, n),
            response=np.fromiter((p.response for p in k), np.float32, n),
            octave=np.fromiter((p.octave for p in k), np.int32, n),
            local=_decode_matrix(wire.local, n, "local"),
            context=_decode_matrix(wire.context, n, "context"),
            holistic=Holistic(h.cols, h.rows, h.bins, np.asarray(h.values, np.float32))
            if has_holistic
            else None,
        )

    @classmethod
    def from_file(cls, path: Union[str, Path]) -> FeatureSet:
        """Reads a feature-set file as `sceneloc extract IMAGE --out FILE` writes it (a
        serialised sceneloc.pb.FeatureSet). OSError when it cannot be read; ValueError, naming
        the file, when it is not a valid feature set."""
        data = Path(path).read_bytes()
        try:
            wire = pb.FeatureSet.FromString(data)
        except DecodeError as e:
            raise ValueError(f"{path}: not a feature-set file ({e})") from e
        try:
            return cls.from_proto(wire)
        except ValueError as e:
            raise ValueError(f"{path}: {e}") from e
