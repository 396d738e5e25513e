"""Fixtures of the sceneloc Python client's tests: real sceneloc-server processes serving
the generated test map (the ctest fixture server/TrainSyntheticMap writes it), and the
files made from its tour.

Paths come from pytest options or, by default, the environment (the ctest python/ClientTests
sets these; client/python/README.md shows a run by hand):
  --server-bin   SCENELOC_SERVER_BIN   build/server/sceneloc-server
  --sceneloc-bin SCENELOC_BIN          build/client/sceneloc
  --test-maps    SCENELOC_TEST_MAPS    build/tests/server/testdata (holds synthetic.scnl)
  --query-jpeg   SCENELOC_QUERY_JPEG   build/tests/server/query.jpg (tour image 3)
A test that needs one that is not given fails (it is not skipped).

The package under test is the installed `sceneloc`. SCENELOC_PY_FROM_SOURCE=1 uses the
source tree instead, with the proto compiled by protoc into a temporary copy of it.
"""
from __future__ import annotations

import atexit
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterator

import pytest

SOURCE_DIR = Path(__file__).resolve().parent.parent  # client/python


def _use_source_tree() -> None:
    """Puts a built copy of the source package first on sys.path."""
    build = Path(tempfile.mkdtemp(prefix="sceneloc_py_"))
    atexit.register(shutil.rmtree, build, ignore_errors=True)
    shutil.copytree(SOURCE_DIR / "src" / "sceneloc", build / "sceneloc",
                    ignore=shutil.ignore_patterns("__pycache__", "sceneloc_pb2.py"))
    proto = SOURCE_DIR.parent.parent / "proto" / "sceneloc.proto"
    subprocess.run([os.environ.get("PROTOC", "protoc"), f"-I{proto.parent}",
                    f"--python_out={build / 'sceneloc'}", proto.name], check=True)
    sys.path.insert(0, str(build))


if os.environ.get("SCENELOC_PY_FROM_SOURCE") == "1":
    _use_source_tree()

import sceneloc  # noqa: E402  (after the source tree was put on the path, if asked)
from server_process import ServerProcess, running_server  # noqa: E402

_PATHS = {
    "server_bin": ("--server-bin", "SCENELOC_SERVER_BIN", "the sceneloc-server binary"),
    "sceneloc_bin": ("--sceneloc-bin", "SCENELOC_BIN", "the sceneloc client binary"),
    "test_maps": ("--test-maps", "SCENELOC_TEST_MAPS", "the folder holding the test map"),
    "query_jpeg": ("--query-jpeg", "SCENELOC_QUERY_JPEG", "query.jpg, tour image 3"),
}
# Generous: the suite may run beside the C++ tests on a 2-core machine.
CALL_TIMEOUT_MS = 30000


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("sceneloc")
    for option, env, help_text in _PATHS.values():
        group.addoption(option, default=os.environ.get(env), help=f"{help_text} (${env})")


def _path(config: pytest.Config, key: str) -> Path:
    option, env, help_text = _PATHS[key]
    value = config.getoption(option)
    if not value:
        pytest.fail(f"{help_text} is not given: pass {option} or set {env}", pytrace=False)
    path = Path(value)
    if not path.exists():
        pytest.fail(f"{help_text}: {path} does not exist ({option} / {env})", pytrace=False)
    return path


@pytest.fixture(scope="session")
def sceneloc_bin(pytestconfig: pytest.Config) -> Path:
    return _path(pytestconfig, "sceneloc_bin")


@pytest.fixture(scope="session")
def query_jpeg(pytestconfig: pytest.Config) -> bytes:
    """The JPEG of tour image 3 of the test map's tour."""
    return _path(pytestconfig, "query_jpeg").read_bytes()


@pytest.fixture(scope="session")
def map_file(pytestconfig: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the test map in a maps folder of its own, so that a build retraining the
    shared one meanwhile changes nothing here."""
    maps = sorted(_path(pytestconfig, "test_maps").glob("*.scnl"))
    if len(maps) != 1:
        pytest.fail(f"expected one *.scnl in the test maps folder, found {maps}", pytrace=False)
    copy = tmp_path_factory.mktemp("maps") / maps[0].name
    shutil.copyfile(maps[0], copy)
    return copy


@pytest.fixture(scope="session")
def map_name(map_file: Path) -> str:
    return map_file.stem


@pytest.fixture(scope="session")
def server_bin(pytestconfig: pytest.Config) -> Path:
    return _path(pytestconfig, "server_bin")


@pytest.fixture(scope="session")
def server(
    server_bin: Path, tmp_path_factory: pytest.TempPathFactory, map_file: Path
) -> Iterator[ServerProcess]:
    """A sceneloc-server serving the test map, for the whole run."""
    yield from running_server(server_bin, ["--maps", str(map_file.parent), "--threads", "2"],
                              tmp_path_factory.mktemp("server") / "server.log")


@pytest.fixture(scope="session")
def second_server(
    server_bin: Path, tmp_path_factory: pytest.TempPathFactory, map_file: Path
) -> Iterator[ServerProcess]:
    """Another process serving the same map file, keeping one session at most (a new one
    evicts the last): it has seen none of `server`'s sessions."""
    yield from running_server(
        server_bin, ["--maps", str(map_file.parent), "--threads", "1", "--max-sessions", "1"],
        tmp_path_factory.mktemp("second_server") / "server.log",
    )


@pytest.fixture
def connect() -> Iterator[Callable[[ServerProcess], sceneloc.Client]]:
    """Makes clients of a test server that do not retry (so that a slow reply fails rather
    than hides), closed at the end of the test."""
    clients: list[sceneloc.Client] = []

    def make(server: ServerProcess) -> sceneloc.Client:
        clients.append(sceneloc.Client(server.endpoint, timeout_ms=CALL_TIMEOUT_MS, retries=0))
        return clients[-1]

    yield make
    for c in clients:
        c.close()


@pytest.fixture
def client(
    connect: Callable[[ServerProcess], sceneloc.Client], server: ServerProcess
) -> sceneloc.Client:
    """A client of `server` (see connect)."""
    return connect(server)


def extract(sceneloc_bin: Path, image: Path, map_file: Path, out: Path, *flags: str) -> Path:
    """Runs `sceneloc extract IMAGE --map-file MAP --out OUT [flags]`."""
    subprocess.run([str(sceneloc_bin), "extract", str(image), "--map-file", str(map_file),
                    "--out", str(out), *flags], check=True, capture_output=True)
    return out


@pytest.fixture(scope="session")
def feature_files(
    pytestconfig: pytest.Config, sceneloc_bin: Path, map_file: Path,
    tmp_path_factory: pytest.TempPathFactory,
) -> dict[str, Path]:
    """query.jpg's feature set as `sceneloc extract --map-file` writes it: "float32" and
    "uint8" (--uint8) descriptors."""
    image = _path(pytestconfig, "query_jpeg")
    out = tmp_path_factory.mktemp("features")
    return {
        "float32": extract(sceneloc_bin, image, map_file, out / "query.pb", "--float32"),
        "uint8": extract(sceneloc_bin, image, map_file, out / "query_uint8.pb", "--uint8"),
    }
