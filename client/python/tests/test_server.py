"""The client against a real sceneloc-server serving the generated test map."""
from __future__ import annotations

import socket
import struct
import time
from pathlib import Path
from typing import Callable

import numpy as np
import pytest

import sceneloc
from server_process import ServerProcess

# query.jpg is the tour's image 3 (tests/server/train_test_map.cc).
QUERY_LOCATION = 3
QUERY_IMAGE = "Image003.jpg"

Connect = Callable[[ServerProcess], sceneloc.Client]


def check_session_state(state: bytes, num_locations: int) -> None:
    """A session's state as server/session_token.h lays it out: "SLS6", the map's places key,
    N locations, S speeds, K tracked locations, frames, B camera bins (0 or 64), ...,
    44 + 4 (N + 1 + K + (K + 1) S) + 2 B bytes."""
    assert state[:4] == b"SLS6"
    locations, speeds, tracked, _frames, bins = struct.unpack_from("<IIIII", state, 8)
    assert locations == num_locations and speeds >= 1 and 1 <= tracked <= locations
    assert bins in (0, 64)
    assert len(state) == 44 + 4 * (locations + 1 + tracked + (tracked + 1) * speeds) + 2 * bins


# A JPEG of a tour image is localised at its own location, LOCALISED, with everything the
# reply holds filled in.
def test_localise_jpeg_answers_a_location_and_a_decision(
    client: sceneloc.Client, map_name: str, query_jpeg: bytes
) -> None:
    reply = client.localise_jpeg(map_name, query_jpeg)
    assert isinstance(reply, sceneloc.LocaliseReply)
    assert reply.best is not None
    assert (reply.best.index, reply.best.image_name) == (QUERY_LOCATION, QUERY_IMAGE)
    assert reply.decision == sceneloc.Decision.LOCALISED and reply.localised
    assert reply.min_confidence <= reply.confidence <= 1
    assert reply.confidence_model in ("calibrated", "paper")
    assert reply.map.name == map_name and reply.map.generation >= 1
    assert reply.timings.decode_ms > 0 and reply.timings.total_ms > 0
    assert reply.num_features > 0
    assert reply.session is None
    assert isinstance(reply.raw, sceneloc.pb.LocaliseReply)
    assert [r.index for r in reply.raw.locations] == [r.index for r in reply.locations]


# top_k and min_confidence reach the server: as many locations as asked for, and the
# threshold the decision used is the request's.
def test_top_k_and_min_confidence_are_sent(
    client: sceneloc.Client, map_name: str, query_jpeg: bytes
) -> None:
    reply = client.localise_jpeg(map_name, query_jpeg, top_k=2, min_confidence=0.25)
    assert len(reply.locations) == 2
    assert reply.min_confidence == pytest.approx(0.25)


# The camera: a frame on its own is read with the tour's (1) unless the request states one,
# and the reply says which.
def test_camera_scale_is_sent_and_reported(
    client: sceneloc.Client, map_name: str, query_jpeg: bytes
) -> None:
    assert client.localise_jpeg(map_name, query_jpeg).camera_scale == pytest.approx(1.0)
    stated = client.localise_jpeg(map_name, query_jpeg, camera_scale=1.25)
    assert stated.camera_scale == pytest.approx(1.25)
    assert stated.best is not None
    # In a session: read with the stated camera; nothing measured yet after one frame.
    first = client.localise_jpeg(map_name, query_jpeg, session="told", camera_scale=1.25)
    assert first.session is not None
    assert first.session.camera_scale == pytest.approx(1.25)
    assert first.session.measured_camera_scale == pytest.approx(1.0)


# The thin-client path: the file `sceneloc extract` wrote, float32 or uint8, read into a
# FeatureSet and sent, is localised like the JPEG it came from (no decoding on the server).
@pytest.mark.parametrize("encoding", ["float32", "uint8"])
def test_localise_features_from_sceneloc_extract(
    client: sceneloc.Client, map_name: str, feature_files: dict[str, Path], encoding: str
) -> None:
    features = sceneloc.FeatureSet.from_file(feature_files[encoding])
    assert features.local.dtype == (np.uint8 if encoding == "uint8" else np.float32)
    reply = client.localise_features(map_name, features)
    assert reply.best is not None and reply.best.index == QUERY_LOCATION
    assert reply.localised
    assert reply.timings.decode_ms == 0
    assert reply.num_features == len(features)


# A FeatureSet made in Python from numpy arrays (float64 descriptors, converted) is what the
# server expects; a sceneloc.pb.FeatureSet is sent as it is.
def test_localise_features_from_arrays_and_from_a_raw_message(
    client: sceneloc.Client, map_name: str, feature_files: dict[str, Path]
) -> None:
    read = sceneloc.FeatureSet.from_file(feature_files["float32"])
    made = sceneloc.FeatureSet(
        image_width=read.image_width, image_height=read.image_height,
        x=read.x.tolist(), y=read.y.tolist(), size=read.size.tolist(),
        angle=read.angle.tolist(), response=read.response.tolist(), octave=read.octave.tolist(),
        local=read.local.astype(np.float64), context=read.context.astype(np.float64),
        holistic=read.holistic,
    )
    assert made.to_proto() == read.to_proto()
    assert client.localise_features(map_name, made).best.index == QUERY_LOCATION
    raw = sceneloc.pb.FeatureSet.FromString(feature_files["float32"].read_bytes())
    assert client.localise_features(map_name, raw).best.index == QUERY_LOCATION
    # Already serialised (a file's bytes), with the other request fields beside them.
    reply = client.localise_features(
        map_name, feature_files["uint8"].read_bytes(), top_k=2, session="bytes-robot"
    )
    assert reply.best.index == QUERY_LOCATION
    assert len(reply.locations) == 2
    assert reply.session is not None and reply.session.frames == 1


# A frame of no place on the route (random features) is answered, not an error: status OK,
# a best guess, decision UNKNOWN.
def test_unknown_place_is_an_answer_not_an_error(client: sceneloc.Client, map_name: str) -> None:
    rng = np.random.default_rng(1)
    n = 300

    def unit_rows() -> np.ndarray:
        rows = rng.random((n, 128))
        return rows / np.linalg.norm(rows, axis=1, keepdims=True)

    features = sceneloc.FeatureSet(
        640, 360, x=rng.random(n) * 640, y=rng.random(n) * 360, size=2 + rng.random(n) * 10,
        angle=rng.random(n) * 360, response=rng.random(n), octave=np.zeros(n, np.int32),
        local=unit_rows(), context=unit_rows(),
    )
    reply = client.localise_features(map_name, features)
    assert reply.decision == sceneloc.Decision.UNKNOWN and not reply.localised
    assert reply.best is not None
    assert reply.confidence < reply.min_confidence


# A session across three frames: the server counts the frames, says how the session began,
# and the client keeps each reply's state to send with the next frame.
def test_session_across_three_frames(
    client: sceneloc.Client, map_name: str, query_jpeg: bytes
) -> None:
    num_locations = client.list_maps()[0].num_locations
    states = []
    for frame in (1, 2, 3):
        reply = client.localise_jpeg(map_name, query_jpeg, session="three-frames")
        assert reply.session is not None
        assert reply.session.name == "three-frames"
        assert reply.session.frames == frame
        assert reply.session.start == (
            sceneloc.SessionStart.NEW if frame == 1 else sceneloc.SessionStart.CONTINUED
        )
        assert reply.session.location == QUERY_LOCATION and reply.session.localised
        # Frames that agree with the track: its support rises, and the probability is the
        # belief's, at most.
        assert 0.5 < reply.session.track_support <= 1
        assert 0 < reply.session.probability <= reply.session.belief <= 1
        check_session_state(reply.session.state, num_locations)
        assert client.session_state(map_name, "three-frames") == reply.session.state
        states.append(reply.session.state)
    assert len(set(states)) == 3
    reset = client.localise_jpeg(map_name, query_jpeg, session="three-frames", reset_session=True)
    assert reset.session.frames == 1 and reset.session.start == sceneloc.SessionStart.RESET


# The state travels: another Client, on another server process that has never seen the
# session, continues it from the state of its last reply (frame 4, CONTINUED).
def test_another_client_on_another_server_continues_from_the_state(
    client: sceneloc.Client, connect: Connect, second_server: ServerProcess, map_name: str,
    query_jpeg: bytes,
) -> None:
    for _ in range(3):
        state = client.localise_jpeg(map_name, query_jpeg, session="travels").session.state
    other = connect(second_server)
    reply = other.localise_jpeg(map_name, query_jpeg, session="travels", session_state=state)
    assert reply.session.frames == 4
    assert reply.session.start == sceneloc.SessionStart.CONTINUED


# The client sends the session's state by itself: on a server that keeps one session at
# most, a session evicted between two of its frames still continues (and, without the
# state, the same session would have started anew).
def test_client_carries_the_state_past_an_eviction(
    connect: Connect, second_server: ServerProcess, map_name: str, query_jpeg: bytes
) -> None:
    robot, other, newcomer = (connect(second_server) for _ in range(3))
    evicted_before = robot.stats().sessions_evicted
    for _ in range(2):
        robot.localise_jpeg(map_name, query_jpeg, session="carried")
    other.localise_jpeg(map_name, query_jpeg, session="evicts-carried")
    assert robot.stats().sessions_evicted > evicted_before
    third = robot.localise_jpeg(map_name, query_jpeg, session="carried")
    assert (third.session.frames, third.session.start) == (3, sceneloc.SessionStart.CONTINUED)
    other.localise_jpeg(map_name, query_jpeg, session="evicts-carried")
    stateless = newcomer.localise_jpeg(map_name, query_jpeg, session="carried")
    assert (stateless.session.frames, stateless.session.start) == (1, sceneloc.SessionStart.NEW)


# list_maps names the served map with its version, size and confidence model.
def test_list_maps(client: sceneloc.Client, map_name: str, map_file: Path) -> None:
    maps = client.list_maps()
    assert [m.version.name for m in maps] == [map_name]
    info = maps[0]
    assert Path(info.path).name == map_file.name
    assert info.version.generation >= 1
    assert info.num_locations == 12 and info.num_landmarks > 0 and info.memory_bytes > 0
    assert info.confidence_model in ("calibrated", "paper") and info.tolerance >= 0
    assert isinstance(info.raw, sceneloc.pb.MapInfo)


# stats counts the requests and their replies by status, and lists the maps.
def test_stats(client: sceneloc.Client, map_name: str, query_jpeg: bytes) -> None:
    before = client.stats()
    client.localise_jpeg(map_name, query_jpeg)
    after = client.stats()
    assert after.requests >= before.requests + 2
    assert after.replies_by_status.get("OK", 0) > before.replies_by_status.get("OK", 0)
    assert after.localise_latency_ms.count > before.localise_latency_ms.count
    assert after.uptime_s > before.uptime_s > 0
    assert [m.version.name for m in after.maps] == [map_name]


# reload_map loads the map again and answers the map now serving, one generation on.
def test_reload_map(client: sceneloc.Client, map_name: str) -> None:
    before = client.list_maps()[0].version
    reloaded = client.reload_map(map_name)
    assert reloaded.version.name == map_name
    assert reloaded.version.generation == before.generation + 1
    assert reloaded.version.checksum == before.checksum


# A map the server does not have is NotFound, naming it, for localise and reload alike.
def test_unknown_map_is_not_found(client: sceneloc.Client, query_jpeg: bytes) -> None:
    with pytest.raises(sceneloc.NotFound) as raised:
        client.localise_jpeg("no-such-map", query_jpeg)
    assert raised.value.status == sceneloc.StatusCode.NOT_FOUND
    assert "no-such-map" in raised.value.message
    assert str(raised.value).startswith("NOT_FOUND: ")
    assert raised.value.reply.status == sceneloc.pb.NOT_FOUND
    with pytest.raises(sceneloc.NotFound):
        client.reload_map("no-such-map")


# Bytes that are not a JPEG are InvalidArgument, saying so.
def test_corrupt_jpeg_is_invalid_argument(client: sceneloc.Client, map_name: str) -> None:
    garbage = np.random.default_rng(7).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    with pytest.raises(sceneloc.InvalidArgument) as raised:
        client.localise_jpeg(map_name, garbage)
    assert raised.value.status == sceneloc.StatusCode.INVALID_ARGUMENT
    assert "JPEG" in raised.value.message


# A raw feature set is the server's to check: descriptors of the wrong length are
# InvalidArgument from the server.
def test_raw_feature_set_is_checked_by_the_server(
    client: sceneloc.Client, map_name: str
) -> None:
    wire = sceneloc.pb.FeatureSet(image_width=640, image_height=360)
    wire.keypoints.add(x=1, y=2, size=3, angle=4, response=5, octave=0)
    wire.local.float32.extend([1.0] + [0.0] * 126)  # 127 values
    wire.context.float32.extend([1.0] + [0.0] * 127)
    with pytest.raises(sceneloc.InvalidArgument, match="local descriptors"):
        client.localise_features(map_name, wire)


def _port_where_nothing_listens() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# Where nothing listens, a call gives up after its attempts (1 + retries, timeout_ms each)
# with Timeout naming the endpoint and the attempts.
def test_timeout_where_nothing_listens() -> None:
    endpoint = f"tcp://127.0.0.1:{_port_where_nothing_listens()}"
    with sceneloc.Client(endpoint, timeout_ms=200, retries=1) as client:
        start = time.monotonic()
        with pytest.raises(sceneloc.Timeout) as raised:
            client.stats()
        elapsed = time.monotonic() - start
        assert client.retries == 1
    assert 0.4 <= elapsed < 2.0
    assert raised.value.endpoint == endpoint and raised.value.attempts == 2
    assert endpoint in str(raised.value) and "2 attempts" in str(raised.value)
    assert raised.value.status is None
    assert isinstance(raised.value, TimeoutError)
    assert isinstance(raised.value, sceneloc.SceneLocError)
