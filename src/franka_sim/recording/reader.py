"""Opening a recording: its configuration and its messages in the order they were recorded,
or one line saying why it cannot be read (truncated, not MCAP, not ours, another version)."""

from __future__ import annotations

import base64
import json
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from franka_sim.protocol.codec import (GRIPPER_STATE_DTYPE, STATE_DTYPE,
                                     VACUUM_GRIPPER_STATE_DTYPE, decode_command)
from franka_sim.recording import FORMAT_VERSION, being_written
from franka_sim.recording.channels import (COMMAND_PREFIX, METADATA_NAME, TOOL_STATE_KEYS,
                                           WORLD_KEYS, robot_channels, world_channels)


class RecordingError(Exception):
    """The file cannot be used; str() is one line for the user."""


@dataclass(frozen=True, slots=True)
class Entry:
    """One recorded message: its channel's key, its robot's index (None: the world's), wall time
    (ns), sequence and bytes."""

    key: str
    robot: int | None
    wall: int
    sequence: int
    data: bytes

    def json(self) -> dict:
        return json.loads(self.data)


class Recording:
    """A recording's metadata and messages; `robots`: its robots' names, by index."""

    def __init__(self, path: Path, metadata: dict, robots: list[str],
                 entries: list[Entry]) -> None:
        self.path, self.metadata, self.robots, self.entries = path, metadata, robots, entries

    def robot(self, name: str | None) -> int:
        """A robot's index by name (None: the first, the lone arm's); RecordingError: none."""
        if name is None:
            return 0
        if name not in self.robots:
            raise RecordingError(f"{self.path}: no robot {name!r} (it holds "
                                 f"{', '.join(self.robots)})")
        return self.robots.index(name)

    def kind(self, name: str | None) -> str:
        """A robot's kind by name (None: the first): "arm" or "base"."""
        return json.loads(self.metadata["robots"])[self.robot(name)]["kind"]

    def of(self, key: str, robot: str | None = None) -> list[Entry]:
        """The messages of one channel: the world's, or one robot's (None: the first)."""
        index = None if key in WORLD_KEYS else self.robot(robot)
        return [e for e in self.entries if e.key == key and e.robot == index]

    def states(self, robot: str | None = None) -> np.ndarray:
        """Every RobotState a robot (None: the first) sent, in order, as one structured array
        (fields by name)."""
        return np.frombuffer(b"".join(e.data for e in self.of("robot_state", robot)),
                             STATE_DTYPE)

    def tool_states(self, robot: str | None = None) -> tuple[str, np.ndarray] | None:
        """(key, the states as one structured array) of the tool whose client took states on a
        robot (None: the first): the Hand's GripperState or the vacuum gripper's; None: none."""
        for service, layout in (("gripper", GRIPPER_STATE_DTYPE),
                                ("vacuum_gripper", VACUUM_GRIPPER_STATE_DTYPE)):
            key = TOOL_STATE_KEYS[service]
            entries = self.of(key, robot)
            if entries:
                return key, np.frombuffer(b"".join(e.data for e in entries), layout)
        return None

    def state_times(self, robot: str | None = None) -> np.ndarray:
        return np.array([e.wall for e in self.of("robot_state", robot)], dtype=np.int64)


def command_of(entry: Entry):
    """(cycle, completed, on_time, decoded RobotCommand) of a /command entry."""
    n, completed, on_time = COMMAND_PREFIX.unpack_from(entry.data)
    return n, completed, on_time, decode_command(entry.data[COMMAND_PREFIX.size:])


def tcp_data(value: dict) -> bytes:
    return base64.b64decode(value["data"])


MCAP_MAGIC = b"\x89MCAP0\r\n"  # what every MCAP file starts with


def open_recording(path: str | Path) -> Recording:
    from mcap.exceptions import EndOfFile, InvalidMagic
    from mcap.records import Channel, Message, Metadata
    from mcap.stream_reader import StreamReader

    path = Path(path)
    try:
        stream = open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"{path}: {exc.strerror or exc}") from None
    topics: dict[int, tuple[str, int | None]] = {}  # channel id: (key, robot index)
    channel_topics: dict[int, str] = {}
    metadata, entries, pending = None, [], []
    with stream:
        try:
            for record in StreamReader(stream, skip_magic=False, validate_crcs=True).records:
                if isinstance(record, Message):
                    pending.append(record)
                elif isinstance(record, Channel):
                    channel_topics[record.id] = record.topic
                elif isinstance(record, Metadata) and record.name == METADATA_NAME:
                    metadata = dict(record.metadata)
        except InvalidMagic:
            raise RecordingError(f"{path}: not an MCAP file") from None
        # Cut short (struct's error: a record cut inside its header), a bad CRC, garbled
        # text, a chunk that does not decompress: each said in one line.
        except Exception as exc:  # noqa: BLE001
            states = sum(channel_topics.get(r.channel_id, "").endswith("/robot_state")
                         for r in pending)
            if being_written(stream):  # (its end, and the chunk being written, still to come)
                raise RecordingError(
                    f"{path}: still being recorded ({states} states so far): its end is "
                    "written when the server recording it stops (serve --record), or "
                    "finishes it (a recording started with POST /recording: DELETE "
                    "/recording)") from None
            if not isinstance(exc, (EndOfFile, struct.error)):
                raise RecordingError(f"{path}: damaged, not as it was written "
                                     f"({type(exc).__name__}: {exc})") from None
            if metadata is None and not pending:
                stream.seek(0)
                if stream.read(len(MCAP_MAGIC)) == MCAP_MAGIC:
                    raise RecordingError(f"{path}: truncated before its first complete "
                                         "record") from None
                raise RecordingError(f"{path}: empty or not an MCAP file") from None
            raise RecordingError(
                f"{path}: truncated (the recording stops without its end; {states} states are "
                "readable: the mcap CLI's `mcap recover` rewrites what is there as a complete "
                "file)") from None
    if metadata is None:
        raise RecordingError(f"{path}: an MCAP file, but not a franka-sim recording")
    version = metadata.get("format_version", "?")
    if version != str(FORMAT_VERSION):
        raise RecordingError(f"{path}: recording format v{version}; this franka-sim reads "
                             f"v{FORMAT_VERSION}")
    from franka_sim.recording.metadata import damage

    if (why := damage(metadata)) is not None:
        raise RecordingError(f"{path}: its metadata is damaged: {why}")
    robots = [robot["name"] for robot in json.loads(metadata["robots"])]
    keys = {channel.topic: (key, None) for key, channel in world_channels().items()}
    for index, name in enumerate(robots):
        keys.update({channel.topic: (key, index)
                     for key, channel in robot_channels(name).items()})
    for channel_id, topic in channel_topics.items():
        if topic in keys:
            topics[channel_id] = keys[topic]
    for record in pending:
        where = topics.get(record.channel_id)
        if where is not None:
            entries.append(Entry(where[0], where[1], record.log_time, record.sequence,
                                 record.data))
    return Recording(path, metadata, robots, entries)
