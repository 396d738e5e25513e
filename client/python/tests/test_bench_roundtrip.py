"""bench_roundtrip.py runs against a real server and reports what it says it does (a
functional check with a few requests; it measures nothing here)."""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import sceneloc
from server_process import ServerProcess

SCRIPT = Path(__file__).resolve().parent.parent / "bench_roundtrip.py"


def run(*args: str) -> subprocess.CompletedProcess[str]:
    """Runs the script with the sceneloc package these tests use (installed or, with
    SCENELOC_PY_FROM_SOURCE, built from the source tree)."""
    package_dir = str(Path(sceneloc.__file__).parent.parent)
    path = os.pathsep.join(filter(None, [package_dir, os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "PYTHONPATH": path}
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True,
                          timeout=120, env=env)


@pytest.mark.parametrize("mode", [[], ["--encode-each"]])
def test_prints_median_and_p99(
    server: ServerProcess, map_name: str, feature_files: dict[str, Path], mode: list[str]
) -> None:
    result = run("--server", server.endpoint, "--map", map_name,
                 "--features", str(feature_files["float32"]), "-n", "3", "--warmup", "1", *mode)
    assert result.returncode == 0, result.stderr
    assert "3 requests after 1 warm-up" in result.stdout
    assert re.search(r"round trip ms\s+median [\d.]+\s+p99 [\d.]+", result.stdout), result.stdout
    assert re.search(r"server ms\s+median [\d.]+\s+p99 [\d.]+", result.stdout), result.stdout
    assert re.search(r"outside ms\s+median [\d.]+\s+p99 [\d.]+", result.stdout), result.stdout


def test_error_reply_exits_1(server: ServerProcess, feature_files: dict[str, Path]) -> None:
    result = run("--server", server.endpoint, "--map", "no-such-map",
                 "--features", str(feature_files["float32"]), "-n", "1", "--warmup", "0")
    assert result.returncode == 1
    assert "NOT_FOUND" in result.stderr
