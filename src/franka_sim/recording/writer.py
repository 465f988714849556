"""The recorder's thread: drains the taps' queue, encodes, and writes MCAP.

Chunked and zstd-compressed; every FLUSH_PERIOD the open chunk is closed and the file flushed,
so a process that dies loses at most that much. The last cycle's stop writes the summary, which
makes the file seekable (readers without it fall back to reading it through).
"""

from __future__ import annotations

import base64
import json
import logging
import threading
import time
from pathlib import Path

import mujoco
from mcap.writer import CompressionType, Writer

from franka_sim.recording import FORMAT_VERSION, recorder as ev
from franka_sim.recording.channels import COMMAND_PREFIX, METADATA_NAME, channels
from franka_sim.recording.wire_json import SERVICES, RequestDecoder, decode_reply
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

FLUSH_PERIOD = 1.0  # s: what a crash may lose at most
DRAIN_PERIOD = 0.05  # s between two looks at the queue
CHUNK_SIZE = 4 * 1024 * 1024  # bytes of messages before a chunk closes by itself

_FREE = int(mujoco.mjtJoint.mjJNT_FREE)


class RecordingWriter:
    def __init__(self, path: Path, metadata: dict, queue, owner) -> None:
        self._file = open(path, "wb")  # OSError here: the caller says the target is unwritable
        self._queue, self._owner = queue, owner
        self._mcap = Writer(self._file, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        self._mcap.start(profile="", library=f"franka-sim recording v{FORMAT_VERSION}")
        self._mcap.add_metadata(METADATA_NAME, {
            "format_version": str(FORMAT_VERSION),
            **{k: v if isinstance(v, str) else json.dumps(v) for k, v in metadata.items()}})
        self._ids = {}
        for key, channel in channels().items():
            schema = self._mcap.register_schema(channel.schema_name, channel.schema_encoding,
                                                channel.schema)
            self._ids[key] = self._mcap.register_channel(channel.topic, channel.message_encoding,
                                                         schema)
        self._decoders: dict[str, RequestDecoder] = {}
        self._free_bodies: list[tuple[str, int]] = []  # (name, qpos address)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="fsim-recorder", daemon=True)
        self._reported_drops = 0
        self._unflushed = False

    def describe_world(self, model) -> None:
        """The free bodies whose poses the qpos records hold (cycle thread, before any)."""
        for body in range(1, model.nbody):
            joint = model.body_jntadr[body]
            if model.body_jntnum[body] == 1 and model.jnt_type[joint] == _FREE:
                self._free_bodies.append((model.body(body).name, int(model.jnt_qposadr[joint])))

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.ident is not None:  # (a recording discarded before it started)
            self._thread.join()
        self._drain()
        self._mcap.finish()
        self._file.close()

    # -- the thread ----------------------------------------------------------------------------------
    def _run(self) -> None:
        last_flush = time.monotonic()
        while not self._stop.wait(DRAIN_PERIOD):
            try:
                self._drain()
                now = time.monotonic()
                if now - last_flush >= FLUSH_PERIOD:
                    self._flush()
                    last_flush = now
            except Exception:  # noqa: BLE001 - keep recording what can be recorded
                log.exception("recording to %s failed", self._file.name)

    def _flush(self) -> None:
        if self._unflushed:
            # Close the open chunk so that it reaches the file. mcap's Writer closes chunks by
            # size only and has no public call for it; without this one (another mcap), a chunk
            # reaches the file once full, and a crash may lose more than the last second.
            finalize = getattr(self._mcap, "_Writer__finalize_chunk", None)
            if finalize is not None:
                finalize()
            self._unflushed = False
        self._file.flush()
        dropped = self._owner.dropped
        if dropped != self._reported_drops:
            self._reported_drops = dropped
            if worth_logging(dropped):
                log.warning("recording fell behind: %d events dropped so far", dropped)

    def _drain(self) -> None:
        queue, write = self._queue, self._write
        while queue:
            write(queue.popleft())

    def _write(self, event: tuple) -> None:
        kind = event[0]
        self._unflushed = True
        if kind == ev.SENT:
            _, data, wall = event
            self._add("robot_state", wall, data, int.from_bytes(data[:8], "little"))
        elif kind == ev.COMMAND:
            _, command, on_time, n, completed, wall = event
            self._add("command", wall, COMMAND_PREFIX.pack(n, completed, on_time)
                      + command.tobytes(), n)
        elif kind == ev.GRIPPER_STATE:
            _, data, wall = event
            self._add("gripper_state", wall, data, 0)
        elif kind == ev.POSES:
            _, n, qpos, wall = event
            bodies = [{"name": name, "position": qpos[a:a + 3].tolist(),
                       "quaternion": qpos[a + 3:a + 7].tolist()}
                      for name, a in self._free_bodies]
            self._json("bodies", wall, {"cycle": n, "qpos": qpos.tolist(), "bodies": bodies}, n)
        elif kind == ev.TCP:
            _, what, event_name, data, n, completed, wall = event
            service = SERVICES.get(what, what)
            if event_name == "open":
                self._decoders[service] = RequestDecoder(service)
            decoder = self._decoders.get(service)
            requests = decoder.feed(data) if data and decoder is not None else []
            self._json("tcp", wall, {
                "cycle": n, "completed": completed, "service": service, "event": event_name,
                "data": base64.b64encode(data).decode(), "requests": requests}, n)
        elif kind == ev.REPLY:
            _, what, data, n, wall = event
            service = SERVICES.get(what, what)
            self._json("reply", wall, {"cycle": n, "service": service,
                                       "replies": [decode_reply(service, data)]}, n)
        elif kind == ev.CONTROL:
            _, operation, arguments, status, result, n, completed, wall = event
            self._json("control", wall, {
                "cycle": n, "completed": completed, "operation": operation,
                "arguments": arguments, "status": status, "result": result}, n)
        elif kind == ev.LOST:
            _, n, filled, wall = event
            self._json("lost_cycle", wall, {
                "cycle": n, "extrapolated": filled == ev.EXTRAPOLATED, "filled": filled}, n)
        elif kind == ev.REJECTED:
            _, reason, source, data, wall = event
            self._json("command_rejected", wall, {
                "reason": reason, "source": source, "size": len(data),
                "data": base64.b64encode(data[:4096]).decode()}, 0)
        elif kind == ev.LOG:
            _, wall, level, name, message = event
            self._json("log", wall, {"level": level, "logger": name, "message": message}, 0)

    def _add(self, key: str, wall: int, data: bytes, sequence: int) -> None:
        self._mcap.add_message(self._ids[key], log_time=wall, data=data, publish_time=wall,
                               sequence=sequence & 0xFFFFFFFF)

    def _json(self, key: str, wall: int, value: dict, sequence: int) -> None:
        self._add(key, wall, json.dumps(value, default=_default).encode(), sequence)


def _default(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)
