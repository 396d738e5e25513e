"""The session state the client keeps and sends, seen on the wire (fake_server.py)."""
from __future__ import annotations

import pytest

import sceneloc
from fake_server import FakeServer
from sceneloc import pb


def session_reply(request: pb.Request, index: int) -> pb.Reply:
    """An OK localise reply to request `index` whose session state is b"state-<index>"."""
    reply = pb.Reply(request_id=request.request_id)
    reply.localise.locations.add(index=3, image_name="Image003.jpg")
    if request.localise.session:
        reply.localise.session.name = request.localise.session
        reply.localise.session.frames = index + 1
        reply.localise.session.state = b"state-%d" % index
    return reply


def sent_states(server: FakeServer) -> list[bytes]:
    return [r.request.localise.session_state for r in server.received]


# Each frame of a session carries the state of the session's last reply, and only that
# session's (per map and name); a frame without a session carries none.
def test_each_frame_carries_the_last_state_of_its_session() -> None:
    with FakeServer(session_reply) as server:
        with sceneloc.Client(server.endpoint, retries=0) as client:
            client.localise_jpeg("lab", b"jpeg", session="a")  # 0
            client.localise_jpeg("lab", b"jpeg", session="a")  # 1
            client.localise_jpeg("lab", b"jpeg", session="b")  # 2: another session
            client.localise_jpeg("hall", b"jpeg", session="a")  # 3: another map
            client.localise_jpeg("lab", b"jpeg")  # 4: no session
            client.localise_jpeg("lab", b"jpeg", session="a")  # 5
            assert client.session_state("lab", "a") == b"state-5"
    assert sent_states(server) == [b"", b"state-0", b"", b"", b"", b"state-1"]


# reset_session sends no state; a state given by the caller is sent instead of the
# client's own; the next frame carries the state of the reply that followed.
def test_reset_and_an_explicit_state() -> None:
    with FakeServer(session_reply) as server:
        with sceneloc.Client(server.endpoint, retries=0) as client:
            client.localise_jpeg("lab", b"jpeg", session="a")  # 0
            client.localise_jpeg("lab", b"jpeg", session="a", reset_session=True)  # 1
            client.localise_jpeg("lab", b"jpeg", session="a", session_state=b"saved")  # 2
            client.localise_jpeg("lab", b"jpeg", session="a")  # 3
    assert sent_states(server) == [b"", b"", b"saved", b"state-2"]
    resets = [r.request.localise.reset_session for r in server.received]
    assert resets == [False, True, False, False]


# After an error reply the client forgets the session's state (the server then continues
# from the state it keeps, if any).
def test_an_error_reply_forgets_the_state() -> None:
    def second_fails(request: pb.Request, index: int) -> pb.Reply:
        if index == 1:
            return pb.Reply(request_id=request.request_id, status=pb.INTERNAL, error="oops")
        return session_reply(request, index)

    with FakeServer(second_fails) as server:
        with sceneloc.Client(server.endpoint, retries=0) as client:
            client.localise_jpeg("lab", b"jpeg", session="a")  # 0
            with pytest.raises(sceneloc.Internal):
                client.localise_jpeg("lab", b"jpeg", session="a")  # 1
            assert client.session_state("lab", "a") is None
            client.localise_jpeg("lab", b"jpeg", session="a")  # 2
            assert client.session_state("lab", "a") == b"state-2"
    assert sent_states(server) == [b"", b"state-0", b""]
