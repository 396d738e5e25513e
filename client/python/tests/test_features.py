"""FeatureSet: made from numpy arrays or read from `sceneloc extract`'s files, checked when
made, and written to the wire exactly as the C++ tools write it."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import sceneloc


def assert_same_bytes(ours: bytes, expected: bytes) -> None:
    """Fails with where two serialised messages first differ: pytest's own explanation of a
    bytes == of a few hundred kilobytes runs for minutes."""
    if ours == expected:
        return
    at = next((i for i, (a, b) in enumerate(zip(ours, expected)) if a != b),
              min(len(ours), len(expected)))
    pytest.fail(
        f"{len(ours)} bytes against {len(expected)} expected; first difference at byte {at}: "
        f"{ours[at:at + 16].hex()} against {expected[at:at + 16].hex()}"
    )


def arrays(n: int = 5, seed: int = 3) -> dict[str, Any]:
    """The fields of a valid FeatureSet of n keypoints with unit float32 descriptors."""
    rng = np.random.default_rng(seed)

    def unit_rows() -> np.ndarray:
        rows = rng.random((n, 128), dtype=np.float32)
        return rows / np.linalg.norm(rows, axis=1, keepdims=True)

    return {
        "image_width": 640, "image_height": 360,
        "x": rng.random(n) * 640, "y": rng.random(n) * 360, "size": 2 + rng.random(n) * 8,
        "angle": rng.random(n) * 360, "response": rng.random(n),
        "octave": np.arange(n), "local": unit_rows(), "context": unit_rows(),
    }


# Arrays are converted to the wire's types: float32 keypoints, int32 octaves, float32
# descriptors (float64 ones converted); uint8 descriptors stay uint8.
def test_made_from_arrays() -> None:
    fields = arrays()
    fields["local"] = fields["local"].astype(np.float64)
    fields["context"] = (fields["context"] * 512).clip(0, 255).astype(np.uint8)
    features = sceneloc.FeatureSet(**fields)
    assert len(features) == 5
    assert features.x.dtype == np.float32 and features.octave.dtype == np.int32
    assert features.local.dtype == np.float32 and features.context.dtype == np.uint8
    wire = features.to_proto()
    assert len(wire.keypoints) == 5 and wire.keypoints[4].octave == 4
    assert len(wire.local.float32) == 5 * 128 and not wire.local.uint8
    assert len(wire.context.uint8) == 5 * 128 and not wire.context.float32
    back = sceneloc.FeatureSet.from_proto(wire)
    np.testing.assert_array_equal(back.local, features.local)
    np.testing.assert_array_equal(back.context, features.context)
    np.testing.assert_array_equal(back.angle, features.angle)


# The keypoints are written with numpy, not a protobuf object each: the bytes must be what
# protobuf itself writes, where proto3 leaves a field out (floats whose bits are all zero, a
# zero octave) and where a varint is long (a negative octave takes 10 bytes).
@pytest.mark.parametrize("uint8", [False, True])
def test_keypoints_written_as_protobuf_writes_them(uint8: bool) -> None:
    n = 200
    fields = arrays(n=n, seed=5)
    rng = np.random.default_rng(7)
    fields["x"][: n // 4] = 0
    fields["y"][::3] = -0.0
    fields["angle"][::7] = 0
    fields["response"][::2] = 0
    octave = rng.integers(-300, 1 << 24, n).astype(np.int32)
    octave[::5] = 0
    octave[:4] = [-(2**31), 2**31 - 1, -1, 127]
    fields["octave"] = octave
    features = sceneloc.FeatureSet(**fields)
    if uint8:
        features = features.as_uint8()
    wire = sceneloc.pb.FeatureSet(image_width=640, image_height=360)
    wire.keypoints.extend(
        sceneloc.pb.Keypoint(x=x, y=y, size=s, angle=a, response=r, octave=o)
        for x, y, s, a, r, o in zip(
            features.x.tolist(), features.y.tolist(), features.size.tolist(),
            features.angle.tolist(), features.response.tolist(), features.octave.tolist()
        )
    )
    ours = features.to_proto()
    wire.local.CopyFrom(ours.local)
    wire.context.CopyFrom(ours.context)
    assert_same_bytes(features.to_bytes(), wire.SerializeToString())
    back = sceneloc.FeatureSet.from_proto(ours)
    np.testing.assert_array_equal(back.octave, octave)
    np.testing.assert_array_equal(back.y.view(np.uint32), features.y.view(np.uint32))  # -0.0


# No keypoints is a valid (if useless) feature set: both descriptor matrices stay empty.
def test_empty_feature_set() -> None:
    features = sceneloc.FeatureSet(**arrays(n=0))
    wire = features.to_proto()
    assert len(features) == 0 and not wire.local.float32 and not wire.local.uint8


@pytest.mark.parametrize(
    "change, match",
    [
        ({"image_width": 0}, "image_width must be a positive integer"),
        ({"image_height": 360.0}, "image_height must be a positive integer"),
        ({"y": np.zeros(4)}, "keypoint y holds 4 values; x holds 5"),
        ({"x": np.zeros((5, 1))}, "keypoint x must be a 1-D array"),
        ({"angle": np.array([0, 1, np.nan, 3, 4])}, "keypoint angle holds a non-finite"),
        ({"local": np.zeros((5, 64), np.float32)}, r"local descriptors must be 5 x 128"),
        ({"context": np.zeros((4, 128), np.float32)}, r"context descriptors must be 5 x 128"),
        ({"local": np.ones((5, 128), np.float32)}, "local descriptor 0 has norm 11.3137"),
        ({"local": np.ones((5, 128), np.int32)}, "float32 .* or uint8, not int32"),
        ({"context": np.full((5, 128), np.inf, np.float32)}, "context descriptors hold a non-fin"),
        ({"holistic": [0.5] * 12}, "holistic must be a sceneloc.Holistic"),
    ],
)
def test_invalid_feature_sets_are_refused(change: dict[str, Any], match: str) -> None:
    with pytest.raises((ValueError, TypeError), match=match):
        sceneloc.FeatureSet(**{**arrays(), **change})


# Zero rows (an empty descriptor) are accepted, as the server accepts them.
def test_zero_descriptor_rows_are_accepted() -> None:
    fields = arrays()
    fields["local"][2] = 0
    assert sceneloc.FeatureSet(**fields).local[2].sum() == 0


@pytest.mark.parametrize(
    "grid, values, match",
    [
        ((2, 2, 3), np.full(11, 0.5), "holds 11 values; its grid 2x2x3 needs 12"),
        ((2, 2, 3), np.full(12, 1.5), r"outside \[0, 1\]"),
        ((65, 1, 1), np.full(65, 0.5), r"cols must be an integer in \[1, 64\]"),
        ((1, 1, 0), np.zeros(0), r"bins must be an integer in \[1, 36\]"),
    ],
)
def test_invalid_holistic_descriptors_are_refused(
    grid: tuple[int, int, int], values: np.ndarray, match: str
) -> None:
    with pytest.raises(ValueError, match=match):
        sceneloc.Holistic(*grid, values)


# A feature set read from `sceneloc extract`'s file and written again is the same message,
# field for field (the C++ tool's wire form), holistic descriptor included.
def test_extract_file_round_trips(feature_files: dict[str, Path]) -> None:
    for path in feature_files.values():
        features = sceneloc.FeatureSet.from_file(path)
        assert features.holistic is not None and features.holistic.values.size > 0
        assert features.to_proto() == sceneloc.pb.FeatureSet.FromString(path.read_bytes())
        # to_bytes, which splices the descriptors' bytes in, writes what the C++ tool wrote.
        assert_same_bytes(features.to_bytes(), path.read_bytes())


# as_uint8 quantises as the C++ client does: the same bytes as `sceneloc extract --uint8`.
def test_as_uint8_matches_the_cpp_quantisation(feature_files: dict[str, Path]) -> None:
    quantised = sceneloc.FeatureSet.from_file(feature_files["float32"]).as_uint8()
    assert quantised.local.dtype == np.uint8
    assert quantised.to_proto() == sceneloc.FeatureSet.from_file(feature_files["uint8"]).to_proto()


# Quantisation rounds halves away from zero, as C++ std::round: 2.5 / 512 becomes 3 (not
# 2, as rounding half to even would make it).
def test_as_uint8_rounds_halves_away_from_zero() -> None:
    fields = arrays()
    row = np.full(128, 2.5 / 512, np.float32)
    row[0] = np.sqrt(1 - 127 * (2.5 / 512) ** 2)  # a unit row
    fields["local"][:] = row
    quantised = sceneloc.FeatureSet(**fields).as_uint8().local
    assert (quantised[:, 0] == 255).all() and (quantised[:, 1:] == 3).all()


# A file that is not a feature set is a ValueError naming it.
def test_from_file_refuses_other_files(tmp_path: Path) -> None:
    garbage = tmp_path / "garbage.pb"
    garbage.write_bytes(b"\x0a\x05ab")
    with pytest.raises(ValueError, match="garbage.pb: not a feature-set file"):
        sceneloc.FeatureSet.from_file(garbage)
    empty = tmp_path / "empty.pb"
    empty.write_bytes(b"")
    with pytest.raises(ValueError, match="empty.pb: image_width must be a positive integer"):
        sceneloc.FeatureSet.from_file(empty)
    wire = sceneloc.FeatureSet(**arrays()).to_proto()
    del wire.local.float32[-1]
    short = tmp_path / "short.pb"
    short.write_bytes(wire.SerializeToString())
    with pytest.raises(ValueError, match="short.pb: local descriptors hold 639 values; 5 keypoin"):
        sceneloc.FeatureSet.from_file(short)
