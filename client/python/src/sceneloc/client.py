"""sceneloc.Client: the Python side of the wire protocol (proto/sceneloc.proto), mirroring
the C++ sceneloc::Client (client/client.h). One DEALER socket to one server; each call
sends a request and waits for its reply.

Timeouts and retries: a call waits timeout_ms for its reply; on a timeout it closes the
socket, opens a fresh one and sends the same request again, up to `retries` more times (the
Lazy Pirate pattern of the ZeroMQ guide), then raises Timeout. Every request kind is safe to
repeat, so a server that restarts between or during calls is survived. An UNAVAILABLE reply
(the server is shutting down; nothing was done) is retried the same way after 50 ms, so
behind a broker another worker answers; so is a reply marked retry_elsewhere (a worker
behind a broker without the map, or of an older protocol), whose status is raised once the
retries are spent. Other error replies are never retried, except
OVERLOADED (nothing was done either): the call waits the reply's retry_after_ms (times 1 to
1.5, so that clients refused together do not come back together) and asks again, for at
most overload_wait_ms in all; then it raises Overloaded.

Every request says which protocol version it speaks (PROTOCOL_VERSION); a reply of a newer
one is refused with Unimplemented, naming both.

Not thread-safe: use one Client per thread (each has its own ZeroMQ context).
"""
from __future__ import annotations

import random
import time
from pathlib import Path
from typing import Optional, Sequence, Union

import zmq
from google.protobuf.message import DecodeError

from .errors import Internal, StatusCode, Timeout, Unimplemented, reply_error
from .features import FeatureSet
from .keys import KeyPair, read_key_file
from .options import ClientOptions, PathLike
from .replies import KeptRun, LocaliseReply, MapInfo, StatsReply
from .requests import check_map, localise_request
from .wire import PROTOCOL_VERSION, field_head, pb

# How long to wait before resending after an UNAVAILABLE or retry_elsewhere reply, seconds
# (as the C++ client).
_ELSEWHERE_PAUSE_S = 0.050
# The least an OVERLOADED retry waits, milliseconds, whatever the server's hint.
_MIN_OVERLOAD_WAIT_MS = 10.0
_UINT64_MASK = (1 << 64) - 1
# Serialised fields sent after a request's own bytes: bytes, or parts joined once.
Appended = Union[bytes, Sequence[Union[bytes, memoryview]]]

class Client:
    """A connection to one sceneloc-server (or a broker in front of many).

    Connects lazily, as ZeroMQ does: no server needs to be up yet. Close it with close(), or
    use it as a context manager. Raises ValueError for invalid options or a malformed
    endpoint, and OSError / ValueError for a key file that cannot be read.
    """

    def __init__(
        self,
        endpoint: str,
        timeout_ms: int = 5000,
        retries: int = 2,
        overload_wait_ms: int = 1000,
        *,
        key_file: Optional[PathLike] = None,
        server_key_file: Optional[PathLike] = None,
    ) -> None:
        if not isinstance(endpoint, str):
            raise TypeError(f"endpoint must be a str, not {type(endpoint).__name__}")
        if endpoint.startswith("routes:"):
            raise ValueError(
                "fleet routes files (routes:FILE) are C++-only; give a broker's endpoint"
            )
        self.options = ClientOptions(
            timeout_ms, retries, overload_wait_ms, key_file, server_key_file
        )
        self.options.validate()
        self.endpoint = endpoint
        # Counters since the client was made: attempts sent again (after a timeout, an
        # UNAVAILABLE or a retry_elsewhere reply), and OVERLOADED replies waited out.
        self.retries = 0
        self.overload_retries = 0
        self._own_key: Optional[KeyPair] = None
        self._server_key: Optional[KeyPair] = None
        if key_file is not None and server_key_file is not None:
            self._own_key = read_key_file(key_file, need_secret=True)
            self._server_key = read_key_file(server_key_file, need_secret=False)
        self._random = random.Random()
        # Ids start at a random point so that replies meant for an earlier client on the
        # same server connection could never be mistaken for ours.
        self._next_id = random.SystemRandom().getrandbits(32) | 1
        # The `state` of each session's last reply, by (map, session name).
        self._session_states: dict[tuple[str, str], bytes] = {}
        self._context = zmq.Context()
        self._socket: Optional[zmq.Socket] = None
        try:
            self._open()
        except BaseException:
            self._context.term()
            raise

    # ------------------------------------------------------------------ typed calls

    def localise_jpeg(
        self,
        map: str,
        jpeg: bytes,
        top_k: int = 0,
        min_confidence: Optional[float] = None,
        session: str = "",
        reset_session: bool = False,
        session_state: bytes = b"",
        camera_scale: Optional[float] = None,
    ) -> LocaliseReply:
        """Localises one camera frame, a whole JPEG file, against `map`. The server extracts
        its features with the map's own settings.

        top_k: ranked locations wanted (0 = the server's matching.top_k).
        min_confidence: answers below it come back with decision UNKNOWN (None = the
          server's matching.min_confidence); in [0, 1].
        session: the robot's session ("" = a frame on its own): the frames of one session
          are filtered together and the reply's `session` holds the filtered answer. Send a
          session's frames one call after another. The client keeps the session's state
          from its last reply and sends it with the next frame, so any server serving the
          map continues it. A call retried after a timeout may add its frame twice.
        reset_session: forget the session's past before this frame.
        session_state: continue from this state (a SessionAnswer.state, e.g. from another
          client or saved across a restart) instead of this client's own.
        camera_scale: how much larger the robot's camera sees things than the tour's camera
          did, when known: focal length over image width, against the tour camera's (e.g.
          1.33 for a 4:3 crop of a 16:9 tour camera's sensor); in [0.25, 4]. None = the
          one the frame's shape implies (the tour's for the tour frame's shape), or in a
          session the scale it learns (SessionAnswer.camera_scale).

        Raises the SceneLocError of an error reply (an unknown place is not one: the reply's
        decision is UNKNOWN), Timeout, or ValueError / TypeError for bad arguments.
        """
        if not isinstance(jpeg, (bytes, bytearray, memoryview)):
            raise TypeError(f"jpeg must be bytes (the whole JPEG file), not {type(jpeg).__name__}")
        if not jpeg:
            raise ValueError("jpeg is empty")
        request = localise_request(
            map, top_k, min_confidence, session, reset_session, session_state, camera_scale
        )
        request.localise.jpeg = bytes(jpeg)
        return LocaliseReply.from_proto(self._typed(request).localise)

    def localise_features(
        self,
        map: str,
        features: Union[FeatureSet, pb.FeatureSet, bytes],
        top_k: int = 0,
        min_confidence: Optional[float] = None,
        session: str = "",
        reset_session: bool = False,
        session_state: bytes = b"",
        camera_scale: Optional[float] = None,
    ) -> LocaliseReply:
        """Localises a frame from its features (the thin-client path): a FeatureSet, a
        sceneloc.pb.FeatureSet, or one already serialised (bytes: e.g. the content of a
        `sceneloc extract` file, or FeatureSet.to_bytes() kept for several calls); the last
        two are sent as they are, for the server to check. They must come from the map's
        extractor settings. The other arguments and the errors are localise_jpeg's.

        The features are not copied into the request message: their serialised bytes are
        appended to the request's (LocaliseRequest.features, field 4 of field 2), and a
        FeatureSet's descriptors are copied once, straight from its arrays into the message
        sent, which is what makes a large feature set cost about what it costs the C++
        client."""
        if isinstance(features, FeatureSet):
            parts = features._wire_parts()
        elif isinstance(features, pb.FeatureSet):
            parts = [features.SerializeToString()]
        elif isinstance(features, (bytes, bytearray, memoryview)):
            parts = [features if isinstance(features, bytes) else bytes(features)]
        else:
            raise TypeError(
                f"features must be a sceneloc.FeatureSet, a sceneloc.pb.FeatureSet or its "
                f"serialised bytes, not {type(features).__name__}"
            )
        request = localise_request(
            map, top_k, min_confidence, session, reset_session, session_state, camera_scale
        )
        size = sum(memoryview(part).nbytes for part in parts)
        features_head = field_head(4, size)
        appended = [field_head(2, len(features_head) + size), features_head, *parts]
        return LocaliseReply.from_proto(self._typed(request, appended).localise)

    def list_maps(self) -> list[MapInfo]:
        """Every map the server serves, by name."""
        request = pb.Request()
        request.list_maps.SetInParent()
        return [MapInfo.from_proto(m) for m in self._typed(request).list_maps.maps]

    def stats(self) -> StatsReply:
        """The server's counters; answered by its I/O thread, so it is the health check."""
        request = pb.Request()
        request.stats.SetInParent()
        return StatsReply.from_proto(self._typed(request).stats)

    def reload_map(self, map: str) -> MapInfo:
        """Loads the map's file again on the server and swaps it in; returns the map now
        serving. A failure (NotFound, DataLoss, FailedPrecondition, Unimplemented, or
        PermissionDenied without an admin key) leaves the old map serving."""
        check_map(map)
        request = pb.Request()
        request.reload_map.map = map
        return MapInfo.from_proto(self._typed(request).reload_map.map)

    def kept_runs(self, map: str = "") -> list[KeptRun]:
        """The runs of frames the server kept where its maps failed (its keep_frames
        settings), of `map` or of every map: by map, then by start. Raises NotFound for a map
        with none, FailedPrecondition when the server keeps no frames, PermissionDenied
        without an admin key."""
        if map:
            check_map(map)
        request = pb.Request()
        request.kept_frames.action = pb.KeptFramesRequest.LIST
        request.kept_frames.map = map
        return [KeptRun.from_proto(r) for r in self._typed(request).kept_frames.runs]

    def fetch_kept_run(self, map: str, run: str, out_dir: PathLike) -> Path:
        """Fetches a kept run page by page into out_dir/<run>/ (000000.jpg, ...: the bytes the
        robot sent) and returns that folder: a walk for `sceneloc-train --extend`. Raises
        NotFound for a run that is not there (and as kept_runs)."""
        check_map(map)
        folder = Path(out_dir) / run
        folder.mkdir(parents=True, exist_ok=True)
        request = pb.Request()
        request.kept_frames.action = pb.KeptFramesRequest.FETCH
        request.kept_frames.map = map
        request.kept_frames.run = run
        while True:
            page = self._typed(request).kept_frames
            for frame in page.frames:
                (folder / Path(frame.file).name).write_bytes(frame.jpeg)
            if not page.frames or not page.runs or page.next_frame >= page.runs[0].frames:
                return folder
            request.kept_frames.first_frame = page.next_frame

    def delete_kept_run(self, map: str, run: str) -> None:
        """Removes a kept run on the server, freeing its quota (as kept_runs for errors)."""
        check_map(map)
        request = pb.Request()
        request.kept_frames.action = pb.KeptFramesRequest.DELETE
        request.kept_frames.map = map
        request.kept_frames.run = run
        self._typed(request)

    def session_state(self, map: str, session: str) -> Optional[bytes]:
        """The state this client will send with the session's next frame: that of its last
        OK reply (None when there is none, or the last reply was an error)."""
        return self._session_states.get((map, session))

    # ------------------------------------------------------------------ raw calls

    def call(self, request: pb.Request, appended: Appended = b"") -> pb.Reply:
        """Sends `request` and returns the server's reply, whatever its status, after the
        retries above. `request` is changed in place: it gets a fresh request_id, this
        client's protocol version and, for a localise request of a session that sets no
        state and does not reset, the state of the session's last reply. Raises Timeout when
        no reply came after every attempt, Internal for a reply that cannot be parsed,
        Unimplemented for a reply of a newer protocol. `appended`: serialised fields sent
        after the request's own bytes (they merge into it; see localise_features), as bytes
        or as a sequence of bytes-like parts joined once into the message."""
        self._live_socket()  # not closed
        request.request_id = self._take_id()
        request.protocol = PROTOCOL_VERSION
        key = self._carry_session_state(request)
        reply = self._send(request, appended)
        # OVERLOADED means nothing was done (a session's frame was not added): asking again
        # is safe. Wait what the server suggests, jittered, within overload_wait_ms in all.
        give_up = time.monotonic() + self.options.overload_wait_ms / 1000
        while reply.status == StatusCode.OVERLOADED:
            hint_ms = max(float(reply.retry_after_ms), _MIN_OVERLOAD_WAIT_MS)
            wait_s = hint_ms * (1 + 0.5 * self._random.random()) / 1000  # x [1, 1.5)
            if time.monotonic() + wait_s > give_up:
                break
            time.sleep(wait_s)
            self.overload_retries += 1
            request.request_id = self._take_id()
            reply = self._send(request, appended)
        if key is not None:
            self._keep_session_state(key, reply)
        return reply

    def close(self) -> None:
        """Closes the socket (unsent requests are dropped) and the ZeroMQ context. Calls
        after it raise RuntimeError; closing again does nothing."""
        if self._socket is not None:
            self._socket.close(linger=0)
            self._socket = None
        if not self._context.closed:
            self._context.term()

    def __enter__(self) -> Client:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals

    def _open(self) -> zmq.Socket:
        """A fresh DEALER socket connected to the endpoint, replacing any earlier one."""
        if self._socket is not None:
            self._socket.close(linger=0)
            self._socket = None
        socket = self._context.socket(zmq.DEALER)
        socket.linger = 0
        if self._own_key is not None and self._server_key is not None:
            socket.curve_serverkey = self._server_key.public_key
            socket.curve_publickey = self._own_key.public_key
            socket.curve_secretkey = self._own_key.secret_key
        try:
            socket.connect(self.endpoint)
        except zmq.ZMQError as e:
            socket.close(linger=0)
            raise ValueError(f"cannot connect to '{self.endpoint}': {e}") from e
        self._socket = socket
        return socket

    def _live_socket(self) -> zmq.Socket:
        if self._socket is None:
            raise RuntimeError("the client is closed")
        return self._socket

    def _take_id(self) -> int:
        request_id = self._next_id
        self._next_id = (self._next_id + 1) & _UINT64_MASK
        return request_id

    def _send(self, request: pb.Request, appended: Appended) -> pb.Reply:
        """Sends `request` (and the fields `appended`) until a reply comes, each retry on a
        fresh socket."""
        if isinstance(appended, (bytes, bytearray, memoryview)):
            appended = (appended,)
        # One copy of a feature set's descriptors, here: a large bytes object made anew is
        # mapped fresh, so every copy of half a megabyte costs about a millisecond.
        data = b"".join((request.SerializeToString(), *appended))
        for attempt in range(self.options.retries + 1):
            if attempt > 0:
                self.retries += 1
            socket = self._open() if attempt > 0 else self._live_socket()
            # copy=False: a large request goes out without one more copy (pyzmq still copies
            # those under its copy_threshold, 64 KiB).
            socket.send_multipart([b"", data], copy=False)
            reply = self._await_reply(socket, request.request_id)
            # UNAVAILABLE: the server (a worker behind a broker, say) is shutting down and
            # did nothing; a fresh socket may reach one that is not, as after a timeout. The
            # same for a worker that says another may do the request (retry_elsewhere).
            if (
                reply is not None
                and (reply.status == StatusCode.UNAVAILABLE or reply.retry_elsewhere)
                and attempt < self.options.retries
            ):
                time.sleep(_ELSEWHERE_PAUSE_S)
                continue
            if reply is not None:
                return reply
        raise Timeout(self.endpoint, self.options.timeout_ms, self.options.retries + 1)

    def _await_reply(self, socket: zmq.Socket, request_id: int) -> Optional[pb.Reply]:
        """The reply to `request_id` on `socket`, or None when the attempt's time is up.
        Replies to other ids (late answers to an abandoned attempt) are dropped."""
        deadline = time.monotonic() + self.options.timeout_ms / 1000
        while True:
            left_ms = (deadline - time.monotonic()) * 1000
            if left_ms <= 0:
                return None
            if not socket.poll(max(1, int(left_ms)), zmq.POLLIN):
                continue
            frames = socket.recv_multipart()
            reply = pb.Reply()
            try:
                reply.ParseFromString(frames[-1])
            except DecodeError as e:
                raise Internal(
                    StatusCode.INTERNAL, f"reply from '{self.endpoint}' cannot be parsed"
                ) from e
            if reply.request_id != request_id:
                continue
            if reply.protocol > PROTOCOL_VERSION:
                raise Unimplemented(
                    StatusCode.UNIMPLEMENTED,
                    f"'{self.endpoint}' replied in sceneloc protocol {reply.protocol}; this "
                    f"client speaks {PROTOCOL_VERSION} (upgrade the client, or reach a server "
                    "of its version)",
                    reply,
                )
            return reply

    def _typed(self, request: pb.Request, appended: Appended = b"") -> pb.Reply:
        """call(), with an error reply raised as its SceneLocError."""
        reply = self.call(request, appended)
        if reply.status != StatusCode.OK:
            raise reply_error(reply)
        return reply

    def _carry_session_state(self, request: pb.Request) -> Optional[tuple[str, str]]:
        """Gives a localise request of a session the state of that session's last reply
        (unless it sets one itself or resets). Returns the session's key (None for none)."""
        if not request.HasField("localise") or not request.localise.session:
            return None
        localise = request.localise
        key = (localise.map, localise.session)
        state = self._session_states.get(key)
        if state is not None and not localise.session_state and not localise.reset_session:
            localise.session_state = state
        return key

    def _keep_session_state(self, key: tuple[str, str], reply: pb.Reply) -> None:
        """Remembers the session's state from its reply; forgets it after an error reply
        (the server then continues from the state it keeps, if any)."""
        if reply.status == StatusCode.OK and reply.localise.HasField("session"):
            self._session_states[key] = reply.localise.session.state
        else:
            self._session_states.pop(key, None)
