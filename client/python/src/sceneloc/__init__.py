"""sceneloc: the Python client of sceneloc-server (proto/sceneloc.proto).

    import sceneloc
    with sceneloc.Client("tcp://127.0.0.1:5555") as client:
        reply = client.localise_jpeg("lab", open("frame.jpg", "rb").read())
        if reply.localised:
            print(reply.best.index, reply.confidence)

See client/python/README.md.
"""
from .client import Client
from .options import ClientOptions
from .errors import (
    DataLoss,
    DeadlineExceeded,
    FailedPrecondition,
    Internal,
    InvalidArgument,
    NotFound,
    Overloaded,
    PermissionDenied,
    ResourceExhausted,
    SceneLocError,
    StatusCode,
    Timeout,
    Unavailable,
    Unimplemented,
)
from .features import FeatureSet, Holistic
from .replies import (
    Decision,
    KeptRun,
    LatencySummary,
    LocaliseReply,
    MapInfo,
    MapVersion,
    RankedLocation,
    SessionAnswer,
    SessionStart,
    StatsReply,
    Timings,
)
from .wire import PROTOCOL_VERSION, pb

__version__ = "0.1.0"

__all__ = [
    "PROTOCOL_VERSION",
    "Client",
    "ClientOptions",
    "DataLoss",
    "DeadlineExceeded",
    "Decision",
    "FailedPrecondition",
    "FeatureSet",
    "Holistic",
    "Internal",
    "InvalidArgument",
    "KeptRun",
    "LatencySummary",
    "LocaliseReply",
    "MapInfo",
    "MapVersion",
    "NotFound",
    "Overloaded",
    "PermissionDenied",
    "RankedLocation",
    "ResourceExhausted",
    "SceneLocError",
    "SessionAnswer",
    "SessionStart",
    "StatsReply",
    "StatusCode",
    "Timeout",
    "Timings",
    "Unavailable",
    "Unimplemented",
    "pb",
]
