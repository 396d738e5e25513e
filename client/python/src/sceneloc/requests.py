"""Requests as they go on the wire, built from a call's arguments after checking them on
the client: a bad argument is a ValueError (or TypeError) saying why, before anything is
sent. Only what does not depend on a server's configuration is checked here; the server
checks its own limits (max_top_k, max_keypoints, image sizes) and answers
RESOURCE_EXHAUSTED."""
from __future__ import annotations

from typing import Optional

from .wire import pb

# Session names: 1..128 printable ASCII characters (proto/wire.h CheckSessionName).
_MAX_SESSION_NAME = 128
# Map names are plain file stems (common/map/map_name.h IsValidMapName).
_MAX_MAP_NAME = 255


def check_map(map: str) -> None:
    """A map name is a plain file stem: letters, digits, '_', '-', '.', not starting with '.'."""
    if not isinstance(map, str):
        raise TypeError(f"map must be a str, not {type(map).__name__}")
    if not map:
        raise ValueError("map name is empty")
    if (
        len(map) > _MAX_MAP_NAME
        or map.startswith(".")
        or not all(c.isascii() and (c.isalnum() or c in "_-.") for c in map)
    ):
        raise ValueError(
            f"'{map}' is not a map name: a plain file stem of letters, digits, '_', '-', '.'"
        )


def _check_session(session: str) -> None:
    """A session name is "" (no session) or 1..128 printable ASCII characters."""
    if not isinstance(session, str):
        raise TypeError(f"session must be a str, not {type(session).__name__}")
    if len(session) > _MAX_SESSION_NAME or not all(" " <= c <= "~" for c in session):
        raise ValueError(
            f"session name {session!r} must be 1..{_MAX_SESSION_NAME} printable ASCII characters"
        )


# LocaliseRequest.camera_scale's range (common/matching/localiser.h kMinCameraScale..).
_MIN_CAMERA_SCALE = 0.25
_MAX_CAMERA_SCALE = 4.0


def localise_request(
    map: str,
    top_k: int,
    min_confidence: Optional[float],
    session: str,
    reset_session: bool,
    session_state: bytes,
    camera_scale: Optional[float] = None,
) -> pb.Request:
    """The Request of a localise call, its query (jpeg or features) still to be set, from
    the call's arguments (Client.localise_jpeg says what they mean) once they are checked."""
    check_map(map)
    if isinstance(top_k, bool) or not isinstance(top_k, int) or top_k < 0:
        raise ValueError(f"top_k must be an integer >= 0 (0 = the server's), not {top_k!r}")
    if min_confidence is not None and (
        isinstance(min_confidence, bool)
        or not isinstance(min_confidence, (int, float))
        or not 0 <= min_confidence <= 1  # NaN fails too
    ):
        raise ValueError(f"min_confidence must be in [0, 1] or None, not {min_confidence!r}")
    if camera_scale is not None and (
        isinstance(camera_scale, bool)
        or not isinstance(camera_scale, (int, float))
        or not _MIN_CAMERA_SCALE <= camera_scale <= _MAX_CAMERA_SCALE  # NaN fails too
    ):
        raise ValueError(
            f"camera_scale must be in [{_MIN_CAMERA_SCALE}, {_MAX_CAMERA_SCALE}] or None, "
            f"not {camera_scale!r}"
        )
    _check_session(session)
    if not isinstance(reset_session, bool):
        raise TypeError(f"reset_session must be a bool, not {type(reset_session).__name__}")
    if not isinstance(session_state, (bytes, bytearray)):
        raise TypeError(f"session_state must be bytes, not {type(session_state).__name__}")
    if (reset_session or session_state) and not session:
        raise ValueError("reset_session and session_state need a session name")
    request = pb.Request()
    localise = request.localise
    localise.map = map
    localise.top_k = top_k
    if min_confidence is not None:
        localise.min_confidence = float(min_confidence)
    if camera_scale is not None:
        localise.camera_scale = float(camera_scale)
    localise.session = session
    localise.reset_session = reset_session
    localise.session_state = bytes(session_state)
    return request
