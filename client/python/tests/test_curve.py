"""CURVE: a server with auth.enabled answers a client holding a listed key pair and the
server's public key, and nothing else (docs/security.md)."""
from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Iterator

import pytest

import sceneloc
from server_process import ServerProcess, running_server


def keygen(sceneloc_bin: Path, name: str, folder: Path) -> str:
    """`sceneloc keygen NAME --dir FOLDER`; returns the clients-file entry it prints."""
    printed = subprocess.run([str(sceneloc_bin), "keygen", name, "--dir", str(folder)],
                             check=True, capture_output=True, text=True).stdout
    return printed.split("auth.clients file:\n", 1)[1]


@pytest.fixture(scope="module")
def keys(sceneloc_bin: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """server.key/.pub, robot.key/.pub (listed) and stranger.key/.pub (not), and clients.yaml."""
    folder = tmp_path_factory.mktemp("keys")
    keygen(sceneloc_bin, "server", folder)
    keygen(sceneloc_bin, "stranger", folder)
    (folder / "clients.yaml").write_text("clients:\n" + keygen(sceneloc_bin, "robot", folder))
    return folder


@pytest.fixture(scope="module")
def auth_server(server_bin: Path, map_file: Path, keys: Path) -> Iterator[ServerProcess]:
    args = ["--maps", str(map_file.parent), "--threads", "1", "--auth", "true",
            "--server-key", str(keys / "server.key"), "--auth-clients", str(keys / "clients.yaml")]
    yield from running_server(server_bin, args, keys / "server.log", **robot_keys(keys))


def robot_keys(keys: Path) -> dict[str, Path]:
    """The Client options of the listed key."""
    return {"key_file": keys / "robot.key", "server_key_file": keys / "server.pub"}


# A listed key is answered; it is not an admin key, so reload_map is PermissionDenied.
def test_listed_key_is_answered(auth_server: ServerProcess, keys: Path, map_name: str) -> None:
    with sceneloc.Client(auth_server.endpoint, timeout_ms=30000, retries=0,
                         **robot_keys(keys)) as client:
        assert [m.version.name for m in client.list_maps()] == [map_name]
        with pytest.raises(sceneloc.PermissionDenied):
            client.reload_map(map_name)


# Without CURVE, or with a key the server does not list, no reply comes at all.
@pytest.mark.parametrize("key", [None, "stranger.key"])
def test_unlisted_client_gets_no_reply(auth_server: ServerProcess, keys: Path, key: str) -> None:
    curve = {} if key is None else {"key_file": keys / key, "server_key_file": keys / "server.pub"}
    with sceneloc.Client(auth_server.endpoint, timeout_ms=300, retries=0, **curve) as client:
        with pytest.raises(sceneloc.Timeout):
            client.stats()


# Key files are checked when the client is made.
def test_key_files_are_checked(keys: Path, tmp_path: Path) -> None:
    endpoint = "tcp://127.0.0.1:9"
    with pytest.raises(ValueError, match="holds no secret_key"):
        sceneloc.Client(endpoint, key_file=keys / "robot.pub", server_key_file=keys / "server.pub")
    mixed = tmp_path / "mixed.key"
    robot, stranger = (keys / "robot.key").read_text(), (keys / "stranger.key").read_text()
    mixed.write_text(robot.split("secret_key")[0] + "secret_key" + stranger.split("secret_key")[1])
    with pytest.raises(ValueError, match="public_key does not belong to secret_key"):
        sceneloc.Client(endpoint, key_file=mixed, server_key_file=keys / "server.pub")
    with pytest.raises(FileNotFoundError):
        sceneloc.Client(endpoint, key_file=keys / "gone.key", server_key_file=keys / "server.pub")
