"""CURVE key files as `sceneloc keygen` writes them (common/keys/keys.h):

  NAME.key  a key pair, secret (mode 0600):   NAME.pub  its public half alone:
    name: robot-7                               name: robot-7
    public_key: "<40 Z85 characters>"           public_key: "<40 Z85 characters>"
    secret_key: "<40 Z85 characters>"

Only those flat `field: value` lines (and # comments) are read: the files keygen writes,
not YAML at large.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional, Union

import zmq
from zmq.utils import z85

Z85_KEY_LENGTH = 40


@dataclasses.dataclass(frozen=True)
class KeyPair:
    name: str
    public_key: bytes  # Z85, 40 bytes
    secret_key: Optional[bytes] = dataclasses.field(default=None, repr=False)  # None in a .pub


def _is_z85_key(text: str) -> bool:
    if len(text) != Z85_KEY_LENGTH:
        return False
    try:
        return len(z85.decode(text)) == 32
    except (ValueError, KeyError, IndexError):  # a character outside Z85's alphabet
        return False


def _fields(path: Union[str, Path]) -> dict[str, str]:
    fields: dict[str, str] = {}
    for number, line in enumerate(Path(path).read_text().splitlines(), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        key, colon, value = line.partition(":")
        if not colon:
            raise ValueError(f"{path}:{number}: not a 'field: value' line of a sceneloc key file")
        value = value.strip()
        if len(value) >= 2 and value[0] == value[-1] and value[0] in "\"'":
            value = value[1:-1]
        fields[key.strip()] = value
    return fields


def read_key_file(path: Union[str, Path], need_secret: bool) -> KeyPair:
    """Reads a .key or .pub file. `need_secret`: a file without a secret key is an error
    (this client's own key). OSError when it cannot be read; ValueError naming the file for
    a missing or malformed key, or a public key that does not belong to the secret one."""
    fields = _fields(path)
    public_key = fields.get("public_key", "")
    secret_key = fields.get("secret_key", "")
    if not _is_z85_key(public_key):
        raise ValueError(f"{path}: public_key must be 40 Z85 characters")
    if not secret_key:
        if need_secret:
            raise ValueError(
                f"{path}: holds no secret_key (a .pub file?); a key pair (.key) is needed"
            )
        return KeyPair(fields.get("name", ""), public_key.encode())
    if not _is_z85_key(secret_key):
        raise ValueError(f"{path}: secret_key must be 40 Z85 characters")
    if zmq.curve_public(secret_key.encode()) != public_key.encode():
        raise ValueError(f"{path}: public_key does not belong to secret_key")
    return KeyPair(fields.get("name", ""), public_key.encode(), secret_key.encode())
