"""The errors a sceneloc.Client call raises.

A reply whose status is not OK becomes the SceneLocError subclass of its status code, so a
caller catches exactly the cases it handles (`except sceneloc.NotFound`) or all of them
(`except sceneloc.SceneLocError`). No reply at all, after every attempt, is Timeout. Bad
arguments are refused before anything is sent, with ValueError (or TypeError).
"""
from __future__ import annotations

import enum
from typing import Optional

from .wire import pb


class StatusCode(enum.IntEnum):
    """The wire's StatusCode (proto/sceneloc.proto), with the same names and numbers."""

    OK = 0
    INVALID_ARGUMENT = 1
    NOT_FOUND = 2
    OVERLOADED = 3
    RESOURCE_EXHAUSTED = 4
    INTERNAL = 5
    DATA_LOSS = 6
    UNAVAILABLE = 7
    FAILED_PRECONDITION = 8
    UNIMPLEMENTED = 9
    DEADLINE_EXCEEDED = 10
    PERMISSION_DENIED = 11


class SceneLocError(Exception):
    """A call that did not succeed. str(e) is "<STATUS>: <message>", as the C++ client's.

    Attributes:
      status:  the StatusCode of the reply; a plain int for a code newer than this client;
               None for Timeout (no reply).
      message: what went wrong, in words (the reply's `error`).
      reply:   the raw sceneloc.pb.Reply, or None when there was none.
    """

    def __init__(
        self, status: Optional[int], message: str, reply: Optional[pb.Reply] = None
    ) -> None:
        self.status = status
        self.message = message
        self.reply = reply
        name = status.name if isinstance(status, StatusCode) else f"STATUS_{status}"
        super().__init__(f"{name}: {message}" if status is not None else message)


class InvalidArgument(SceneLocError):
    """A malformed request, JPEG or feature set (the server said so)."""


class NotFound(SceneLocError):
    """No map of that name (or, for reload_map, no file to load it from)."""


class Overloaded(SceneLocError):
    """Too much work was queued, and waiting it out took longer than overload_wait_ms.

    retry_after_ms: the server's estimate of when a retry would be admitted, milliseconds.
    """

    def __init__(
        self, status: Optional[int], message: str, reply: Optional[pb.Reply] = None
    ) -> None:
        super().__init__(status, message, reply)
        self.retry_after_ms = reply.retry_after_ms if reply is not None else 0


class ResourceExhausted(SceneLocError):
    """A size cap of the server was exceeded (message, image, keypoints, top_k)."""


class Internal(SceneLocError):
    """A bug or a library failure on the server, or a reply that cannot be parsed."""


class DataLoss(SceneLocError):
    """reload_map: the map file is truncated or corrupt (the old map keeps serving)."""


class Unavailable(SceneLocError):
    """The server is shutting down, still so after every retry."""


class FailedPrecondition(SceneLocError):
    """Well-formed but unusable, e.g. a map that fails its self-test on reload."""


class Unimplemented(SceneLocError):
    """E.g. a map file of a newer format version, or a peer of a newer protocol version."""


class DeadlineExceeded(SceneLocError):
    """The request's work passed the server's limits.max_request_ms; the message says where."""


class PermissionDenied(SceneLocError):
    """This client's key may not do this (reload_map needs an admin key), or was removed."""


class Timeout(SceneLocError, TimeoutError):
    """No reply within timeout_ms on any of the attempts (status None).

    endpoint: the server's endpoint; attempts: how many times the request was sent.
    """

    def __init__(self, endpoint: str, timeout_ms: int, attempts: int) -> None:
        super().__init__(
            None, f"no reply from '{endpoint}' within {timeout_ms} ms ({attempts} attempts)"
        )
        self.endpoint = endpoint
        self.attempts = attempts


_ERROR_CLASSES: dict[StatusCode, type[SceneLocError]] = {
    StatusCode.INVALID_ARGUMENT: InvalidArgument,
    StatusCode.NOT_FOUND: NotFound,
    StatusCode.OVERLOADED: Overloaded,
    StatusCode.RESOURCE_EXHAUSTED: ResourceExhausted,
    StatusCode.INTERNAL: Internal,
    StatusCode.DATA_LOSS: DataLoss,
    StatusCode.UNAVAILABLE: Unavailable,
    StatusCode.FAILED_PRECONDITION: FailedPrecondition,
    StatusCode.UNIMPLEMENTED: Unimplemented,
    StatusCode.DEADLINE_EXCEEDED: DeadlineExceeded,
    StatusCode.PERMISSION_DENIED: PermissionDenied,
}


def reply_error(reply: pb.Reply) -> SceneLocError:
    """The exception for a reply whose status is not OK (REQUIRES: reply.status != OK)."""
    try:
        status = StatusCode(reply.status)
    except ValueError:  # a code added to the protocol after this client was built
        return SceneLocError(reply.status, reply.error, reply)
    return _ERROR_CLASSES[status](status, reply.error, reply)
