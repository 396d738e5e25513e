"""The settings of a sceneloc.Client (the C++ ClientOptions, client/client.h)."""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional, Union

PathLike = Union[str, Path]


@dataclasses.dataclass(frozen=True)
class ClientOptions:
    """A Client's settings (the C++ ClientOptions)."""

    # How long one attempt waits for its reply, milliseconds (>= 1).
    timeout_ms: int = 5000
    # Attempts after the first one timed out (or was answered UNAVAILABLE), each on a fresh
    # socket (>= 0).
    retries: int = 2
    # Longest a call spends waiting out OVERLOADED replies before asking again,
    # milliseconds (>= 0; 0 = raise the first Overloaded at once).
    overload_wait_ms: int = 1000
    # CURVE, for a server with auth.enabled: this client's key pair (a .key file) and the
    # server's public key (its .pub). Both or neither. A client whose key the server does
    # not list gets no reply at all: its calls raise Timeout.
    key_file: Optional[PathLike] = None
    server_key_file: Optional[PathLike] = None

    def validate(self) -> None:
        """Raises ValueError for an invalid setting."""
        for name, least in (("timeout_ms", 1), ("retries", 0), ("overload_wait_ms", 0)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < least:
                raise ValueError(f"{name} must be an integer >= {least}, not {value!r}")
        if (self.key_file is None) != (self.server_key_file is None):
            raise ValueError(
                "CURVE needs both key files: this client's key pair (key_file) and the "
                "server's public key (server_key_file)"
            )
