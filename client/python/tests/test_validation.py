"""Bad arguments are refused on the client, before anything is sent, with a clear error.

The client points where nothing listens: an argument that got through would be sent and
end in Timeout, not in the error expected."""
from __future__ import annotations

from typing import Any, Iterator

import pytest

import sceneloc

NOWHERE = "tcp://127.0.0.1:9"  # the discard port: nothing answers there


@pytest.fixture
def client() -> Iterator[sceneloc.Client]:
    with sceneloc.Client(NOWHERE, timeout_ms=50, retries=0) as c:
        yield c


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"map": ""}, ValueError, "map name is empty"),
        ({"map": "../etc/passwd"}, ValueError, "not a map name"),
        ({"map": ".hidden"}, ValueError, "not a map name"),
        ({"map": 7}, TypeError, "map must be a str"),
        ({"min_confidence": 1.5}, ValueError, r"min_confidence must be in \[0, 1\]"),
        ({"min_confidence": -0.1}, ValueError, r"min_confidence must be in \[0, 1\]"),
        ({"min_confidence": float("nan")}, ValueError, r"min_confidence must be in \[0, 1\]"),
        ({"camera_scale": 0.2}, ValueError, r"camera_scale must be in \[0.25, 4.0\]"),
        ({"camera_scale": 4.5}, ValueError, r"camera_scale must be in \[0.25, 4.0\]"),
        ({"camera_scale": float("nan")}, ValueError, r"camera_scale must be in \[0.25, 4.0\]"),
        ({"camera_scale": True}, ValueError, r"camera_scale must be in \[0.25, 4.0\]"),
        ({"top_k": -1}, ValueError, "top_k must be an integer >= 0"),
        ({"top_k": 2.5}, ValueError, "top_k must be an integer >= 0"),
        ({"session": "x" * 129}, ValueError, "1..128 printable ASCII"),
        ({"session": "robot\n7"}, ValueError, "1..128 printable ASCII"),
        ({"session": "robôt"}, ValueError, "1..128 printable ASCII"),
        ({"reset_session": True}, ValueError, "need a session name"),
        ({"session_state": b"x"}, ValueError, "need a session name"),
        ({"session": "a", "session_state": "text"}, TypeError, "session_state must be bytes"),
    ],
)
def test_bad_localise_arguments(
    client: sceneloc.Client, kwargs: dict[str, Any], error: type, match: str
) -> None:
    arguments = {"map": "lab", **kwargs}
    with pytest.raises(error, match=match):
        client.localise_jpeg(jpeg=b"\xff\xd8", **arguments)


@pytest.mark.parametrize(
    "jpeg, error, match",
    [(b"", ValueError, "jpeg is empty"), ("frame.jpg", TypeError, "jpeg must be bytes")],
)
def test_bad_jpeg_argument(client: sceneloc.Client, jpeg: Any, error: type, match: str) -> None:
    with pytest.raises(error, match=match):
        client.localise_jpeg("lab", jpeg)


def test_bad_features_argument(client: sceneloc.Client) -> None:
    with pytest.raises(TypeError, match="features must be a sceneloc.FeatureSet"):
        client.localise_features("lab", "not features")  # type: ignore[arg-type]


def test_bad_reload_argument(client: sceneloc.Client) -> None:
    with pytest.raises(ValueError, match="not a map name"):
        client.reload_map("maps/lab")


@pytest.mark.parametrize(
    "endpoint, options, error, match",
    [
        (NOWHERE, {"timeout_ms": 0}, ValueError, "timeout_ms must be an integer >= 1"),
        (NOWHERE, {"timeout_ms": True}, ValueError, "timeout_ms must be an integer >= 1"),
        (NOWHERE, {"retries": -1}, ValueError, "retries must be an integer >= 0"),
        (NOWHERE, {"overload_wait_ms": -1}, ValueError, "overload_wait_ms must be an integer >= 0"),
        (NOWHERE, {"key_file": "a.key"}, ValueError, "both key files"),
        ("routes:fleet.yaml", {}, ValueError, "C\\+\\+-only"),
        ("no-transport", {}, ValueError, "cannot connect to 'no-transport'"),
        (None, {}, TypeError, "endpoint must be a str"),
    ],
    ids=["timeout_ms", "timeout_ms-bool", "retries", "overload_wait_ms", "one-key-file",
         "routes", "malformed-endpoint", "endpoint-type"],
)
def test_invalid_options_are_refused(
    endpoint: Any, options: dict[str, Any], error: type, match: str
) -> None:
    with pytest.raises(error, match=match):
        sceneloc.Client(endpoint, **options)


# A closed client refuses calls; closing twice is harmless.
def test_closed_client() -> None:
    client = sceneloc.Client(NOWHERE)
    client.close()
    client.close()
    with pytest.raises(RuntimeError, match="closed"):
        client.stats()
