"""sceneloc-server as a child process, as a user runs it: bound to tcp://127.0.0.1:* (the
port it picked is read back from its log), stopped with SIGTERM."""
from __future__ import annotations

import re
import signal
import subprocess
import time
from pathlib import Path
from typing import Any, Iterator, Sequence

import sceneloc

# "serving N map(s) on tcp://127.0.0.1:PORT with ..." (server/server_main.cc)
_SERVING = re.compile(r"serving \d+ map\(s\) on (tcp://\S+)")
# Generous: the suite may run beside the C++ tests on a 2-core machine.
SERVER_START_TIMEOUT_S = 60


class ServerProcess:
    """A running sceneloc-server; its stdout and stderr go to `log_path`."""

    def __init__(self, binary: Path, args: Sequence[str], log_path: Path) -> None:
        self.log_path = log_path
        # Time budgets as the C++ tests' under ASan (tests/server/server_test_support.cc): a
        # slow build or a busy machine must not turn slowness into DEADLINE_EXCEEDED or
        # OVERLOADED. No test here is about them.
        command = [str(binary), "--endpoint", "tcp://127.0.0.1:*", "--summary-interval", "0",
                   "--log-level", "info", "--max-request-ms", "120000",
                   "--max-queue-wait-ms", "120000", *args]
        with open(log_path, "wb") as log:
            self.process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT)
        self.endpoint = ""

    def log(self) -> str:
        return self.log_path.read_text(errors="replace")

    def wait_until_serving(self, timeout_s: float, **client_options: Any) -> None:
        """Waits for the log line naming the endpoint, then for a stats reply to a Client
        made with `client_options` (e.g. its CURVE keys). Raises RuntimeError with the log
        when the server exits or the time runs out."""
        deadline = time.monotonic() + timeout_s
        while not self.endpoint:
            match = _SERVING.search(self.log())
            if match:
                self.endpoint = match.group(1)
            elif self.process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"sceneloc-server did not start:\n{self.log()}")
            else:
                time.sleep(0.05)
        left_ms = max(1, int((deadline - time.monotonic()) * 1000))
        options = {"timeout_ms": left_ms, "retries": 0, **client_options}
        with sceneloc.Client(self.endpoint, **options) as client:
            client.stats()

    def stop(self, timeout_s: float = 30) -> int:
        """SIGTERM, then its exit status (killed, -9, when it does not exit in time)."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


def running_server(
    binary: Path, args: Sequence[str], log_path: Path, **client_options: Any
) -> Iterator[ServerProcess]:
    """Starts sceneloc-server with `args`, yields it once it answers stats (asked with
    `client_options`), then stops it with SIGTERM and checks that it exited 0. For a pytest
    fixture to `yield from`."""
    server = ServerProcess(binary, args, log_path)
    try:
        server.wait_until_serving(SERVER_START_TIMEOUT_S, **client_options)
        yield server
    finally:
        status = server.stop()
    assert status == 0, f"sceneloc-server exited {status}:\n{server.log()}"
