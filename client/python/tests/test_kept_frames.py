"""Frames kept where the map failed (keep_frames): a real sceneloc-server process that keeps
a session's UNKNOWN frames, listed, fetched and deleted through the client, and kept across
a restart of the server."""
from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Callable, Iterator

import pytest

import sceneloc
from server_process import ServerProcess, running_server

Connect = Callable[[ServerProcess], sceneloc.Client]


@contextlib.contextmanager
def keeping_server(
    server_bin: Path, map_file: Path, kept: Path, log: Path
) -> Iterator[ServerProcess]:
    # No session answer reaches a min_confidence of 1: every frame of a session is UNKNOWN,
    # so a streak of two keeps frames.
    yield from running_server(
        server_bin,
        ["--maps", str(map_file.parent), "--threads", "2", "--keep-frames", str(kept),
         "--keep-frames-after", "2", "--sequence-min-confidence", "1"],
        log,
    )


def wait_for_frames(client: sceneloc.Client, map_name: str, frames: int) -> list[sceneloc.KeptRun]:
    """The map's runs once they hold `frames` frames (the server writes on its own thread)."""
    deadline = time.monotonic() + 30
    while True:
        try:
            runs = client.kept_runs(map_name)
            if sum(r.frames for r in runs) >= frames:
                return runs
        except sceneloc.NotFound:
            pass
        assert time.monotonic() < deadline, "the kept frames never showed"
        time.sleep(0.05)


def test_kept_frames_are_listed_fetched_deleted_and_survive_a_restart(
    server_bin: Path, map_file: Path, map_name: str, query_jpeg: bytes, tmp_path: Path,
    connect: Connect,
) -> None:
    kept = tmp_path / "kept"
    with keeping_server(server_bin, map_file, kept, tmp_path / "server1.log") as process:
        client = connect(process)
        for _ in range(3):
            reply = client.localise_jpeg(map_name, query_jpeg, session="rover 1")
            assert reply.session is not None
            assert reply.session.decision == sceneloc.Decision.UNKNOWN
        runs = wait_for_frames(client, map_name, 3)
        assert len(runs) == 1
        run = runs[0]
        assert (run.map, run.session, run.frames, run.anchor_place) == (map_name, "rover 1", 3, -1)
        assert run.run.endswith("-rover_1")
        assert run.bytes > 3 * len(query_jpeg)
        folder = client.fetch_kept_run(map_name, run.run, tmp_path / "fetched")
        names = sorted(p.name for p in folder.iterdir())
        assert names == ["000000.jpg", "000001.jpg", "000002.jpg"]
        assert all(p.read_bytes() == query_jpeg for p in folder.iterdir())
        with pytest.raises(sceneloc.NotFound):
            client.fetch_kept_run(map_name, "no-such-run", tmp_path / "fetched")
        with pytest.raises(ValueError):
            client.kept_runs("../etc")
    # Stopped with SIGTERM (exit status 0 checked). A new process on the same folder lists
    # the run, and deleting it frees the quota.
    with keeping_server(server_bin, map_file, kept, tmp_path / "server2.log") as process:
        client = connect(process)
        assert [r.run for r in client.kept_runs()] == [run.run]
        client.delete_kept_run(map_name, run.run)
        with pytest.raises(sceneloc.NotFound):
            client.kept_runs(map_name)
        assert not (kept / map_name / run.run).exists()


def test_a_server_that_keeps_nothing_says_so(
    client: sceneloc.Client, map_name: str
) -> None:
    with pytest.raises(sceneloc.FailedPrecondition, match="keep_frames.dir"):
        client.kept_runs(map_name)
