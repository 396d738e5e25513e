"""Timeouts, retries, OVERLOADED, stale replies and session states, against a scripted
server on a real ROUTER socket (fake_server.py)."""
from __future__ import annotations

import time

import pytest

import sceneloc
from fake_server import (
    FakeServer,
    answer_after,
    gaps,
    identities,
    never,
    request_ids,
    stats_reply,
)
from sceneloc import pb


def overloaded(request: pb.Request, retry_after_ms: int) -> pb.Reply:
    return stats_reply(request, pb.OVERLOADED, error="queue full", retry_after_ms=retry_after_ms)


# A request goes out as [empty frame][serialised Request], as a REQ socket would send it.
def test_request_is_an_empty_frame_then_the_request() -> None:
    with FakeServer(lambda request, _: stats_reply(request)) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000) as client:
            client.stats()
    [received] = server.received
    assert len(received.frames) == 2 and received.frames[0] == b""
    assert received.request.HasField("stats")


# A server that never answers: each attempt times out, each retry arrives with the same id
# on a fresh connection, and then the call raises Timeout.
def test_times_out_and_retries_on_a_fresh_socket() -> None:
    with FakeServer(never) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=100, retries=2) as client:
            start = time.monotonic()
            with pytest.raises(sceneloc.Timeout) as raised:
                client.list_maps()
            elapsed = time.monotonic() - start
            assert client.retries == 2
    assert raised.value.attempts == 3
    assert 0.3 <= elapsed < 2.0
    assert len(server.received) == 3
    assert len(set(request_ids(server.received))) == 1
    assert len(identities(server.received)) == 3


# A request whose first attempt went unanswered is answered on the retry.
def test_answer_on_the_retry_is_returned() -> None:
    with FakeServer(answer_after(1, stats_reply)) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=100, retries=1) as client:
            assert client.stats().uptime_s == 1.0
            assert client.retries == 1


# Replies to other request ids (a late answer to an abandoned attempt) are dropped: the
# call returns the reply to its own request.
def test_stale_replies_are_dropped() -> None:
    def stale_then_right(request: pb.Request, _: int) -> list[pb.Reply]:
        stale = stats_reply(request, pb.NOT_FOUND, error="stale")
        stale.request_id = request.request_id - 1
        return [stale, stats_reply(request)]

    with FakeServer(stale_then_right) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=0) as client:
            assert client.stats().uptime_s == 1.0


# A late reply to a call that timed out, arriving during the next call on the same socket,
# is not taken for the next call's.
def test_late_reply_of_a_timed_out_call_is_not_taken_for_the_next() -> None:
    def late(request: pb.Request, index: int) -> list[pb.Reply]:
        if index == 0:
            return []
        late_reply = stats_reply(request, pb.NOT_FOUND, error="late")
        late_reply.request_id = request.request_id - 1
        return [late_reply, stats_reply(request)]

    with FakeServer(late) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=100, retries=0) as client:
            with pytest.raises(sceneloc.Timeout):
                client.stats()
            assert client.stats().uptime_s == 1.0


# UNAVAILABLE (a server shutting down) is retried after 50 ms on a fresh socket, within
# `retries`; the answer that follows is returned.
def test_unavailable_is_retried_on_a_fresh_socket() -> None:
    def unavailable_first(request: pb.Request, index: int) -> pb.Reply:
        return stats_reply(request, pb.UNAVAILABLE if index == 0 else pb.OK)

    with FakeServer(unavailable_first) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=1) as client:
            assert client.stats().uptime_s == 1.0
            assert client.retries == 1
    assert gaps(server.received)[0] >= 0.05
    assert len(identities(server.received)) == 2


# UNAVAILABLE on every attempt is raised as Unavailable.
def test_unavailable_after_every_retry_is_raised() -> None:
    with FakeServer(lambda request, _: stats_reply(request, pb.UNAVAILABLE)) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=1) as client:
            with pytest.raises(sceneloc.Unavailable):
                client.stats()
    assert len(server.received) == 2


# OVERLOADED is waited out: the call asks again (with a fresh id) after the server's hint,
# jittered to at most 1.5 times it, and returns the answer that follows.
def test_overloaded_is_waited_out_after_the_hint() -> None:
    hint_ms = 200

    def overloaded_twice(request: pb.Request, index: int) -> pb.Reply:
        return overloaded(request, hint_ms) if index < 2 else stats_reply(request)

    with FakeServer(overloaded_twice) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, overload_wait_ms=1000) as client:
            assert client.stats().uptime_s == 1.0
            assert client.overload_retries == 2
            assert client.retries == 0
    assert len(server.received) == 3
    for gap in gaps(server.received):
        assert hint_ms / 1000 <= gap < 1.5 * hint_ms / 1000 + 0.08
    assert len(set(request_ids(server.received))) == 3


# The wait is bounded by overload_wait_ms: when the next wait would pass it, Overloaded is
# raised, carrying the hint; with 0, the first OVERLOADED is.
@pytest.mark.parametrize(
    "overload_wait_ms, hint_ms, min_retries", [(0, 50, 0), (200, 300, 0), (700, 100, 3)]
)
def test_overload_wait_is_bounded(overload_wait_ms: int, hint_ms: int, min_retries: int) -> None:
    with FakeServer(lambda request, _: overloaded(request, hint_ms)) as server:
        with sceneloc.Client(server.endpoint, overload_wait_ms=overload_wait_ms) as client:
            start = time.monotonic()
            with pytest.raises(sceneloc.Overloaded) as raised:
                client.stats()
            elapsed = time.monotonic() - start
            assert client.overload_retries >= min_retries
            assert len(server.received) == client.overload_retries + 1
    assert elapsed < overload_wait_ms / 1000 + 0.15
    assert raised.value.retry_after_ms == hint_ms
    assert raised.value.status == sceneloc.StatusCode.OVERLOADED
    assert str(raised.value) == "OVERLOADED: queue full"


def _class_name(status_name: str) -> str:
    return "".join(word.capitalize() for word in status_name.split("_"))


# Every error status of the protocol becomes its own exception class, under SceneLocError,
# with the status, the server's message and the raw reply.
@pytest.mark.parametrize("name", [n for n in pb.StatusCode.keys() if n != "OK"])
def test_every_error_status_has_its_exception(name: str) -> None:
    status = pb.StatusCode.Value(name)
    error_class = getattr(sceneloc, _class_name(name))
    def error_reply(request: pb.Request, _: int) -> pb.Reply:
        return stats_reply(request, status, error="what went wrong")

    with FakeServer(error_reply) as server:
        with sceneloc.Client(server.endpoint, retries=0, overload_wait_ms=0) as client:
            with pytest.raises(error_class) as raised:
                client.stats()
    assert type(raised.value) is error_class and isinstance(raised.value, sceneloc.SceneLocError)
    assert raised.value.status == status and raised.value.status.name == name
    assert raised.value.message == "what went wrong"
    assert str(raised.value) == f"{name}: what went wrong"
    assert raised.value.reply.status == status


# A status this client does not know (a newer server) is a SceneLocError with its number.
def test_unknown_status_is_a_scenelocerror() -> None:
    with FakeServer(lambda request, _: stats_reply(request, 99, error="new")) as server:
        with sceneloc.Client(server.endpoint, retries=0) as client:
            with pytest.raises(sceneloc.SceneLocError) as raised:
                client.stats()
    assert type(raised.value) is sceneloc.SceneLocError
    assert raised.value.status == 99 and str(raised.value) == "STATUS_99: new"


# A reply that cannot be parsed is Internal, at once (not retried).
def test_unparseable_reply_is_internal() -> None:
    truncated = b"\x0a\x05ab"  # a length-delimited field cut short
    with FakeServer(lambda _request, _index: truncated) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=2) as client:
            with pytest.raises(sceneloc.Internal, match="cannot be parsed"):
                client.stats()
            assert client.retries == 0
    assert len(server.received) == 1


# A reply marked retry_elsewhere (a worker behind a broker without the map) is retried on a
# fresh socket like UNAVAILABLE; once the retries are spent, its status is raised.
@pytest.mark.parametrize("answered_on_retry", [True, False])
def test_retry_elsewhere_is_retried_on_a_fresh_socket(answered_on_retry: bool) -> None:
    def elsewhere(request: pb.Request, index: int) -> pb.Reply:
        if answered_on_retry and index > 0:
            return stats_reply(request)
        return stats_reply(request, pb.NOT_FOUND, error="no map on this worker",
                           retry_elsewhere=True)

    with FakeServer(elsewhere) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=2) as client:
            if answered_on_retry:
                assert client.stats().uptime_s == 1.0
            else:
                with pytest.raises(sceneloc.NotFound, match="on this worker"):
                    client.stats()
            retries = client.retries
    assert retries == (1 if answered_on_retry else 2)
    assert len(identities(server.received)) == retries + 1
    assert all(gap >= 0.05 for gap in gaps(server.received))


# Every request says the protocol it speaks; a reply of a newer protocol is refused as
# Unimplemented naming both versions, at once.
def test_protocol_version() -> None:
    with FakeServer(lambda request, _: stats_reply(request, protocol=2)) as server:
        with sceneloc.Client(server.endpoint, timeout_ms=5000, retries=2) as client:
            with pytest.raises(sceneloc.Unimplemented) as raised:
                client.stats()
    assert "protocol 2; this client speaks 1" in str(raised.value)
    assert [r.request.protocol for r in server.received] == [sceneloc.PROTOCOL_VERSION] == [1]
