"""A scripted stand-in for sceneloc-server on a real ZeroMQ ROUTER socket, for the client's
retry, overload and session-state logic: each request is recorded and answered with what a
handler returns for it: nothing, or one or more replies (stale ones included; bytes are
sent as they are, as a body that is not a Reply)."""
from __future__ import annotations

import dataclasses
import threading
import time
from typing import Callable, Sequence, Union

import zmq

from sceneloc import pb

Answer = Union[pb.Reply, bytes]
Handler = Callable[[pb.Request, int], Union[None, Answer, Sequence[Answer]]]


@dataclasses.dataclass
class Received:
    """One request as it arrived."""

    time: float  # time.monotonic()
    identity: bytes  # the ROUTER's id of the connection it came on
    frames: list[bytes]  # the frames after the identity
    request: pb.Request


class FakeServer:
    """Answers request i (0-based, in arrival order) with handler(request, i). Use as a
    context manager; `endpoint` is where it listens, `received` what came."""

    def __init__(self, handler: Handler) -> None:
        self._handler = handler
        self._context = zmq.Context()
        self._socket = self._context.socket(zmq.ROUTER)
        self._socket.linger = 0
        self._socket.bind("tcp://127.0.0.1:*")
        self.endpoint: str = self._socket.getsockopt_string(zmq.LAST_ENDPOINT)
        self.received: list[Received] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)

    def __enter__(self) -> FakeServer:
        self._thread.start()
        return self

    def __exit__(self, *exc_info: object) -> None:
        self._stop.set()
        self._thread.join()
        self._socket.close(linger=0)
        self._context.term()

    def _serve(self) -> None:
        while not self._stop.is_set():
            if not self._socket.poll(20, zmq.POLLIN):
                continue
            identity, *frames = self._socket.recv_multipart()
            request = pb.Request.FromString(frames[-1])
            self.received.append(Received(time.monotonic(), identity, frames, request))
            replies = self._handler(request, len(self.received) - 1)
            if replies is None:
                continue
            for reply in [replies] if isinstance(replies, (pb.Reply, bytes)) else replies:
                body = reply if isinstance(reply, bytes) else reply.SerializeToString()
                self._socket.send_multipart([identity, b"", body])


def stats_reply(request: pb.Request, status: int = pb.OK, **fields: object) -> pb.Reply:
    """A reply to `request` (its id) with `status`; an OK one carries an empty stats."""
    reply = pb.Reply(request_id=request.request_id, status=status, **fields)
    if status == pb.OK:
        reply.stats.uptime_s = 1.0
    return reply


def never(_request: pb.Request, _index: int) -> None:
    """A handler that answers nothing."""
    return None


def answer_after(skipped: int, reply: Callable[[pb.Request], pb.Reply]) -> Handler:
    """A handler that ignores the first `skipped` requests and answers the rest."""
    return lambda request, index: reply(request) if index >= skipped else None


def gaps(received: Sequence[Received]) -> list[float]:
    """Seconds between consecutive arrivals."""
    return [b.time - a.time for a, b in zip(received, received[1:])]


def identities(received: Sequence[Received]) -> set[bytes]:
    return {r.identity for r in received}


def request_ids(received: Sequence[Received]) -> list[int]:
    return [r.request.request_id for r in received]
