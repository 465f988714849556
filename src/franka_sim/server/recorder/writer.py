"""The recorder's thread: drains the taps' queue, encodes, and writes MCAP
(recording/channels.py says what each channel holds).

Chunked and zstd-compressed; every FLUSH_PERIOD the open chunk is closed and the file flushed,
so a process that dies loses at most that much. The header is flushed at once: a target that
takes no bytes (a full disk) is refused when the recording starts. Should a write fail later,
the recording stops there (one log line; `failure` says why): the file keeps what reached it.
The last cycle's stop writes the summary, which makes the file seekable (readers without it
fall back to reading it through). Cycles repeated
one after another are written as one run (first, last), before whatever came after them.
"""

from __future__ import annotations

import base64
import json
import logging
import math
import threading
import time
from pathlib import Path

from mcap.writer import CompressionType, Writer

from franka_sim.log_names import ContextThread
from franka_sim.recording import FORMAT_VERSION
from franka_sim.recording.channels import (COMMAND_PREFIX, METADATA_NAME, TOOL_STATE_KEYS,
                                           robot_channels, world_channels)
from franka_sim.recording.wire_json import SERVICES, RequestDecoder, decode_reply
from franka_sim.robot.events import EXTRAPOLATED
from franka_sim.server.recorder import events as ev
from franka_sim.server.recorder.target import Target
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

FLUSH_PERIOD = 1.0  # s: what a crash may lose at most
DRAIN_PERIOD = 0.05  # s between two looks at the queue
CHUNK_SIZE = 4 * 1024 * 1024  # bytes of messages before a chunk closes by itself

class RecordingWriter:
    def __init__(self, path: Path, metadata: dict, robots: list[str], queue, owner) -> None:
        # OSError here: the caller says the target cannot be written (target.py)
        self.target = Target(path)
        self._file = self.target.stream
        self._path = path
        self._queue, self._owner = queue, owner
        self._mcap = Writer(self._file, chunk_size=CHUNK_SIZE, compression=CompressionType.ZSTD)
        self._mcap.start(profile="", library=f"franka-sim recording v{FORMAT_VERSION}")
        self._mcap.add_metadata(METADATA_NAME, {
            "format_version": str(FORMAT_VERSION),
            **{k: v if isinstance(v, str) else json.dumps(v) for k, v in metadata.items()}})
        schemas: dict[str, int] = {}
        self._ids: dict = {}  # key, or (robot index, key): its channel id
        for key, channel in world_channels().items():
            self._ids[key] = self._register(channel, schemas)
        for robot, name in enumerate(robots):
            for key, channel in robot_channels(name).items():
                self._ids[robot, key] = self._register(channel, schemas)
        self._decoders: dict[tuple[int, str], RequestDecoder] = {}
        self.free_bodies: list[tuple[str, int]] = []  # (name, qpos address)
        self._repeats: list[int] | None = None  # [first, last, wall] of a run being kept
        self._stop = threading.Event()
        self._thread = ContextThread(target=self._run, name="fsim-recorder", daemon=True)
        self._reported_drops = 0
        self._unflushed = False
        self.failure: OSError | None = None  # the write that stopped the recording
        self._file.flush()  # (OSError here too: the caller says the target is unwritable)

    def _register(self, channel, schemas: dict[str, int]) -> int:
        schema = schemas.get(channel.schema_name)
        if schema is None:
            schema = schemas[channel.schema_name] = self._mcap.register_schema(
                channel.schema_name, channel.schema_encoding, channel.schema)
        return self._mcap.register_channel(channel.topic, channel.message_encoding, schema)

    def start(self) -> None:
        """The file takes its place (OSError: it cannot), then the thread drains the queue."""
        self.target.commit()
        self._thread.start()

    def abandon(self) -> None:
        """Never started: nothing of it stays, and the target is as it was."""
        self.target.abandon()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.ident is not None:  # (a recording discarded before it started)
            self._thread.join()
        try:
            if self.failure is None:
                self._drain()
                self._write_repeats()
                self._mcap.finish()
            self._file.close()
        except OSError as exc:  # (the file is closed all the same)
            self._failed(exc)

    def _failed(self, exc: OSError) -> None:
        if self.failure is None:
            self.failure = exc
            log.error("recording to %s stopped: %s (the file keeps what reached it before)",
                      self._path, exc.strerror or exc)

    # -- the thread ----------------------------------------------------------------------------------
    def _run(self) -> None:
        last_flush, errors = time.monotonic(), 0
        while not self._stop.wait(DRAIN_PERIOD):
            try:
                self._drain()
                now = time.monotonic()
                if now - last_flush >= FLUSH_PERIOD:
                    self._flush()
                    last_flush = now
            except OSError as exc:  # the file takes no more (a full disk, an I/O error)
                self._failed(exc)
                self._queue.clear()
                return
            except Exception:  # noqa: BLE001 - keep recording what can be recorded
                errors += 1
                if worth_logging(errors):
                    log.exception("recording to %s: an event could not be written (%d so far)",
                                  self._path, errors)

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
        if kind == ev.REPEATED:
            _, n, wall = event
            runs = self._repeats
            if runs is not None and runs[1] == n - 1:
                runs[1] = n
                return
            self._write_repeats()
            self._repeats = [n, n, wall]
            return
        if self._repeats is not None:
            self._write_repeats()  # before what came after them
        if kind == ev.SENT:
            _, robot, data, wall = event
            self._add((robot, "robot_state"), wall, data, int.from_bytes(data[:8], "little"))
        elif kind == ev.COMMAND:
            _, robot, command, on_time, n, completed, wall = event
            self._add((robot, "command"), wall, COMMAND_PREFIX.pack(n, completed, on_time)
                      + command.tobytes(), n)
        elif kind == ev.SKIPPED:
            _, first, last, wall = event
            self._json("skipped", wall, {"first": first, "last": last}, first)
        elif kind == ev.TOOL_STATE:
            _, robot, service, data, wall = event
            self._add((robot, TOOL_STATE_KEYS[service]), wall, data, 0)
        elif kind == ev.POSES:
            _, n, qpos, wall = event
            bodies = [{"name": name, "position": qpos[a:a + 3].tolist(),
                       "quaternion": qpos[a + 3:a + 7].tolist()}
                      for name, a in self.free_bodies]
            self._json("bodies", wall, {"cycle": n, "qpos": qpos.tolist(), "bodies": bodies}, n)
        elif kind == ev.TCP:
            _, robot, what, event_name, data, n, completed, wall = event
            service = SERVICES.get(what, what)
            if event_name == "open":
                self._decoders[robot, service] = RequestDecoder(service)
            decoder = self._decoders.get((robot, service))
            requests = decoder.feed(data) if data and decoder is not None else []
            self._json((robot, "tcp"), wall, {
                "cycle": n, "completed": completed, "service": service, "event": event_name,
                "data": base64.b64encode(data).decode(), "requests": requests}, n)
        elif kind == ev.REPLY:
            _, robot, what, data, n, wall = event
            service = SERVICES.get(what, what)
            decoder = self._decoders.get((robot, service))
            dialect = None if decoder is None else decoder.dialect
            self._json((robot, "reply"), wall, {
                "cycle": n, "service": service,
                "replies": [decode_reply(service, data, dialect)]}, n)
        elif kind == ev.CONTROL:
            _, robot, operation, arguments, status, result, n, completed, wall = event
            self._json((robot, "control"), wall, {
                "cycle": n, "completed": completed, "operation": operation,
                "arguments": arguments, "status": status, "result": result}, n)
        elif kind == ev.LOST:
            _, robot, n, filled, wall = event
            self._json((robot, "lost_cycle"), wall, {
                "cycle": n, "extrapolated": filled == EXTRAPOLATED, "filled": filled}, n)
        elif kind == ev.REJECTED:
            _, robot, reason, source, data, wall = event
            self._json((robot, "command_rejected"), wall, {
                "reason": reason, "source": source, "size": len(data),
                "data": base64.b64encode(data[:4096]).decode()}, 0)
        elif kind == ev.LOG:
            _, wall, level, name, message, robot = event
            line = {"level": level, "logger": name, "message": message}
            if robot is not None:  # (a line about one robot of several: its name)
                line["robot"] = robot
            self._json("log", wall, line, 0)

    def _write_repeats(self) -> None:
        runs, self._repeats = self._repeats, None
        if runs is not None:
            first, last, wall = runs
            self._json("repeated", wall, {"first": first, "last": last}, first)

    def _add(self, key, wall: int, data: bytes, sequence: int) -> None:
        self._mcap.add_message(self._ids[key], log_time=wall, data=data, publish_time=wall,
                               sequence=sequence & 0xFFFFFFFF)

    def _json(self, key, wall: int, value: dict, sequence: int) -> None:
        try:
            text = json.dumps(value, default=_default, allow_nan=False)
        except ValueError:  # a non-finite number (a hostile request's width, say): strict JSON
            text = json.dumps(_spelled(value), default=_default, allow_nan=False)  # for Foxglove
        self._add(key, wall, text.encode(), sequence)


def _spelled(value):
    """`value` with each non-finite float written as the string JavaScript would print."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, dict):
        return {k: _spelled(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_spelled(v) for v in value]
    if hasattr(value, "tolist"):
        return _spelled(value.tolist())
    return value


def _default(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    return str(value)
