"""Opening a recording: its configuration and its messages in the order they were recorded,
or one line saying why it cannot be read (truncated, not MCAP, not ours, another version)."""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from franka_sim.protocol.codec import STATE_DTYPE, decode_command
from franka_sim.recording import FORMAT_VERSION
from franka_sim.recording.channels import COMMAND_PREFIX, METADATA_NAME, channels


class RecordingError(Exception):
    """The file cannot be used; str() is one line for the user."""


@dataclass(frozen=True, slots=True)
class Entry:
    """One recorded message: its channel's key, wall time (ns), sequence and bytes."""

    key: str
    wall: int
    sequence: int
    data: bytes

    def json(self) -> dict:
        return json.loads(self.data)


class Recording:
    def __init__(self, path: Path, metadata: dict, entries: list[Entry]) -> None:
        self.path, self.metadata, self.entries = path, metadata, entries

    def of(self, key: str) -> list[Entry]:
        return [e for e in self.entries if e.key == key]

    def states(self) -> np.ndarray:
        """Every RobotState sent, in order, as one structured array (fields by name)."""
        states = [e.data for e in self.entries if e.key == "robot_state"]
        return np.frombuffer(b"".join(states), STATE_DTYPE)

    def state_times(self) -> np.ndarray:
        return np.array([e.wall for e in self.entries if e.key == "robot_state"], dtype=np.int64)


def command_of(entry: Entry):
    """(cycle, completed, on_time, decoded RobotCommand) of a /command entry."""
    n, completed, on_time = COMMAND_PREFIX.unpack_from(entry.data)
    return n, completed, on_time, decode_command(entry.data[COMMAND_PREFIX.size:])


def tcp_data(value: dict) -> bytes:
    return base64.b64decode(value["data"])


def open_recording(path: str | Path) -> Recording:
    from mcap.exceptions import EndOfFile, InvalidMagic, McapError
    from mcap.records import Channel, Message, Metadata
    from mcap.stream_reader import StreamReader

    path = Path(path)
    try:
        stream = open(path, "rb")
    except OSError as exc:
        raise RecordingError(f"{path}: {exc.strerror or exc}") from None
    keys = {c.topic: k for k, c in channels().items()}
    topics: dict[int, str] = {}
    metadata, entries = None, []
    with stream:
        try:
            for record in StreamReader(stream, skip_magic=False).records:
                if isinstance(record, Message):
                    key = topics.get(record.channel_id)
                    if key is not None:
                        entries.append(Entry(key, record.log_time, record.sequence, record.data))
                elif isinstance(record, Channel):
                    if record.topic in keys:
                        topics[record.id] = keys[record.topic]
                elif isinstance(record, Metadata) and record.name == METADATA_NAME:
                    metadata = dict(record.metadata)
        except InvalidMagic:
            raise RecordingError(f"{path}: not an MCAP file") from None
        except EndOfFile:
            if metadata is None and not entries:
                raise RecordingError(f"{path}: empty or not an MCAP file") from None
            raise RecordingError(
                f"{path}: truncated (the recording stops without its end; "
                f"{sum(e.key == 'robot_state' for e in entries)} states are readable: "
                "`mcap recover` rewrites what is there as a complete file)") from None
        except McapError as exc:
            raise RecordingError(f"{path}: damaged MCAP ({exc})") from None
    if metadata is None:
        raise RecordingError(f"{path}: an MCAP file, but not a franka-sim recording")
    version = metadata.get("format_version", "?")
    if version != str(FORMAT_VERSION):
        raise RecordingError(f"{path}: recording format v{version}; this franka-sim reads "
                             f"v{FORMAT_VERSION}")
    return Recording(path, metadata, entries)
