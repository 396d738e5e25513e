"""Typed views of the server's replies (proto/sceneloc.proto), as small frozen dataclasses.

Every field mirrors the proto field of the same name; the top-level replies keep the
message they were read from as `raw` (sceneloc.pb.*), for fields this client predates.
"""
from __future__ import annotations

import dataclasses
import enum
from typing import Optional

from .wire import pb


class Decision(enum.IntEnum):
    """Whether to act on an answer. UNKNOWN (the zero value) means do not."""

    UNKNOWN = 0  # below min_confidence: perhaps a place that is not on the route
    LOCALISED = 1  # confidence >= the request's (or the server's) min_confidence


class SessionStart(enum.IntEnum):
    """How a session's answer began."""

    CONTINUED = 0  # the session's earlier frames were used
    NEW = 1  # the server had no such session (first frame, expired or evicted)
    RESET = 2  # the request asked for reset_session
    MAP_RELOADED = 3  # the map's places changed since the session's last frame: started again


def _enum(kind: type[enum.IntEnum], value: int) -> int:
    """`value` as a member of `kind`, or the plain int for a value newer than this client."""
    try:
        return kind(value)
    except ValueError:
        return value


@dataclasses.dataclass(frozen=True)
class RankedLocation:
    index: int  # tour location
    image_name: str  # tour image file name
    likelihood: float  # L(l)
    inliers: int  # epipolar inliers when verified, else -1

    @classmethod
    def from_proto(cls, m: pb.RankedLocation) -> RankedLocation:
        return cls(m.index, m.image_name, m.likelihood, m.inliers)


@dataclasses.dataclass(frozen=True)
class MapVersion:
    """Which map answered, exactly."""

    name: str
    generation: int  # 1 on the first load of this name, +1 on every successful load
    checksum: int  # CRC-32 of the map file's payload

    @classmethod
    def from_proto(cls, m: pb.MapVersion) -> MapVersion:
        return cls(m.name, m.generation, m.checksum)


@dataclasses.dataclass(frozen=True)
class Timings:
    """Milliseconds per stage inside the server."""

    queue_ms: float  # waiting for a worker
    decode_ms: float  # JPEG decoding (0 for a feature set)
    extract_ms: float  # SIFT (0 for a feature set); parsing and checking a feature set
    descriptor_ms: float
    neighbourhood_ms: float
    likelihood_ms: float
    holistic_ms: float
    verify_ms: float
    total_ms: float  # received by the server's I/O thread to reply built
    place_ms: float  # the coarse stage picking candidate places (0 on maps searched whole)

    @classmethod
    def from_proto(cls, m: pb.Timings) -> Timings:
        return cls(
            m.queue_ms, m.decode_ms, m.extract_ms, m.descriptor_ms, m.neighbourhood_ms,
            m.likelihood_ms, m.holistic_ms, m.verify_ms, m.total_ms, m.place_ms,
        )


@dataclasses.dataclass(frozen=True)
class SessionAnswer:
    """A session's answer: the frame's evidence filtered with the session's earlier frames."""

    name: str
    location: int  # the most probable tour location
    image_name: str  # its tour image
    probability: float  # P(the robot is within the map's tolerance of `location`)
    off_map: float  # P(the robot is off the route)
    decision: int  # a Decision: LOCALISED when probability >= min_confidence
    min_confidence: float  # the server's sequence.min_confidence
    frames: int  # frames of the session so far, this one included
    start: int  # a SessionStart
    # How much larger the robot's camera sees things than the tour's, as the session read
    # this frame: the request's camera_scale, else what it has learnt (1 = the tour's camera,
    # also until learnt; 0 from an older server).
    camera_scale: float
    # What the session has measured of its camera so far: beside a stated camera_scale, it
    # tells whether that is right (0 from an older server).
    measured_camera_scale: float
    # The session's filter state after this frame; the client sends it with the session's
    # next request by itself (Client.session_state).
    state: bytes = dataclasses.field(repr=False)
    # The filter's belief within the tolerance of `location` alone, and how far recent frames
    # support the track it follows (0-1): probability = track_support x belief + (1 -
    # track_support) x the frame's own, at most the belief (0 from an older server).
    belief: float = 0.0
    track_support: float = 0.0

    @property
    def localised(self) -> bool:
        return self.decision == Decision.LOCALISED

    @classmethod
    def from_proto(cls, m: pb.SessionAnswer) -> SessionAnswer:
        return cls(
            m.name, m.location, m.image_name, m.probability, m.off_map,
            _enum(Decision, m.decision), m.min_confidence, m.frames,
            _enum(SessionStart, m.start), m.camera_scale, m.measured_camera_scale, m.state,
            m.belief, m.track_support,
        )


@dataclasses.dataclass(frozen=True)
class LocaliseReply:
    """One frame's answer. An unknown place is not an error: decision is UNKNOWN."""

    locations: tuple[RankedLocation, ...]  # best first
    # With confidence_model "calibrated": P(the best location is within `tolerance` frames of
    # the true one). With "paper": L1 / (L1 + L2), not a probability.
    confidence: float
    decision: int  # a Decision
    confidence_model: str  # "calibrated" or "paper"
    min_confidence: float  # the threshold the decision used
    tolerance: int  # the map's tolerance, frames
    map: MapVersion  # the map snapshot that answered
    timings: Timings
    num_features: int  # query features matched
    descriptor_matches: int  # feature-landmark pairs with S_D >= s_min
    session: Optional[SessionAnswer]  # set when the request named a session
    # The camera scale the answer was read with: the request's camera_scale, else in a
    # session the one it learnt, else 1 (the tour's camera); 0 from an older server.
    camera_scale: float
    raw: pb.LocaliseReply = dataclasses.field(repr=False, compare=False)

    @property
    def best(self) -> Optional[RankedLocation]:
        """The best ranked location, or None when there is none."""
        return self.locations[0] if self.locations else None

    @property
    def localised(self) -> bool:
        """Whether to act on the best location (decision LOCALISED)."""
        return self.decision == Decision.LOCALISED

    @classmethod
    def from_proto(cls, m: pb.LocaliseReply) -> LocaliseReply:
        return cls(
            locations=tuple(RankedLocation.from_proto(r) for r in m.locations),
            confidence=m.confidence,
            decision=_enum(Decision, m.decision),
            confidence_model=m.confidence_model,
            min_confidence=m.min_confidence,
            tolerance=m.tolerance,
            map=MapVersion.from_proto(m.map),
            timings=Timings.from_proto(m.timings),
            num_features=m.num_features,
            descriptor_matches=m.descriptor_matches,
            session=SessionAnswer.from_proto(m.session) if m.HasField("session") else None,
            camera_scale=m.camera_scale,
            raw=m,
        )


@dataclasses.dataclass(frozen=True)
class MapInfo:
    """A map the server serves."""

    version: MapVersion
    path: str
    num_locations: int
    num_landmarks: int
    memory_bytes: int
    loaded_utc: str  # ISO 8601
    confidence_model: str  # "calibrated" or "paper": the confidence the map supports
    tolerance: int  # frames: what "correct" means for its confidence
    trained_by: str  # the sceneloc version that trained it ("" from older servers)
    trained_utc: str  # when it was trained, ISO 8601
    raw: pb.MapInfo = dataclasses.field(repr=False, compare=False)

    @classmethod
    def from_proto(cls, m: pb.MapInfo) -> MapInfo:
        return cls(
            MapVersion.from_proto(m.version), m.path, m.num_locations, m.num_landmarks,
            m.memory_bytes, m.loaded_utc, m.confidence_model, m.tolerance, m.trained_by,
            m.trained_utc, m,
        )


@dataclasses.dataclass(frozen=True)
class LatencySummary:
    count: int
    p50: float
    p90: float
    p99: float
    max: float

    @classmethod
    def from_proto(cls, m: pb.LatencySummary) -> LatencySummary:
        return cls(m.count, m.p50, m.p90, m.p99, m.max)


@dataclasses.dataclass(frozen=True)
class KeptRun:
    """A session's frames the server kept in a row where its map failed (keep_frames):
    from the first frame of an UNKNOWN streak until the session was LOCALISED again."""

    map: str
    run: str  # "<UTC start>-<session>": the folder its frames are in
    session: str
    client: str  # the key name of the session's client ("" without auth)
    started_utc: str
    last_utc: str
    frames: int
    bytes: int
    map_checksum: int  # the map version that failed on them
    # The session's last LOCALISED answer before the run (anchor_place -1: none).
    anchor_place: int
    anchor_name: str
    anchor_probability: float
    anchor_utc: str

    @classmethod
    def from_proto(cls, m: pb.KeptRun) -> KeptRun:
        return cls(
            m.map, m.run, m.session, m.client, m.started_utc, m.last_utc, m.frames, m.bytes,
            m.map_checksum, m.anchor_place, m.anchor_name, m.anchor_probability, m.anchor_utc,
        )


@dataclasses.dataclass(frozen=True)
class StatsReply:
    """The server's counters (its health check: answered by its I/O thread)."""

    uptime_s: float
    requests: int  # received, of every kind, including refused ones
    in_flight: int  # queued or being worked on
    replies_by_status: dict[str, int]  # StatusCode name -> count
    localise_latency_ms: LatencySummary  # successful localise requests
    map_loads: int
    map_load_failures: int
    map_unloads: int  # maps removed because their file was deleted
    maps: tuple[MapInfo, ...]
    replies_undelivered: int  # the client had gone, or had stopped reading
    sessions: int  # live sessions, all maps
    session_memory_bytes: int
    sessions_evicted: int  # dropped for sessions.max_sessions
    sessions_expired: int  # dropped after sessions.idle_timeout_s unused
    raw: pb.StatsReply = dataclasses.field(repr=False, compare=False)

    @classmethod
    def from_proto(cls, m: pb.StatsReply) -> StatsReply:
        return cls(
            uptime_s=m.uptime_s,
            requests=m.requests,
            in_flight=m.in_flight,
            replies_by_status=dict(m.replies_by_status),
            localise_latency_ms=LatencySummary.from_proto(m.localise_latency_ms),
            map_loads=m.map_loads,
            map_load_failures=m.map_load_failures,
            map_unloads=m.map_unloads,
            maps=tuple(MapInfo.from_proto(i) for i in m.maps),
            replies_undelivered=m.replies_undelivered,
            sessions=m.sessions,
            session_memory_bytes=m.session_memory_bytes,
            sessions_evicted=m.sessions_evicted,
            sessions_expired=m.sessions_expired,
            raw=m,
        )
