"""TCP traffic as JSON a person can read: each request and reply decoded by the wire tables.

Runs on the writer thread (and in readers), never on the server's threads.
"""

from __future__ import annotations

from enum import Enum

from construct import Container, ListContainer

from franka_sim.protocol import gripper_messages as gm
from franka_sim.protocol import robot_messages as rm
from franka_sim.protocol import vacuum_gripper_messages as vm
from franka_sim.protocol.framing import FrameReader, ProtocolError, decode_request
from franka_sim.protocol.robot_versions import DIALECTS

# The endpoints' names for their service, and the recording's.
SERVICES = {"FCI": "robot", "gripper": "hand", "vacuum_gripper": "vacuum_gripper"}
_TABLES = {
    "robot": (rm.CommandHeader, rm.REQUEST_SIZES, rm.REQUEST_STRUCTS, rm.RESPONSE_STRUCTS,
              rm.Command),
    "hand": (gm.GripperHeader, gm.GRIPPER_REQUEST_SIZES, gm.GRIPPER_REQUEST_STRUCTS,
             gm.GRIPPER_RESPONSE_STRUCTS, gm.GripperCommand),
    "vacuum_gripper": (vm.VacuumGripperHeader, vm.VACUUM_GRIPPER_REQUEST_SIZES,
                       vm.VACUUM_GRIPPER_REQUEST_STRUCTS, vm.VACUUM_GRIPPER_RESPONSE_STRUCTS,
                       vm.VacuumGripperCommand),
}


def plain(value):
    """A construct value as JSON-able data (enums by name, bytes by their length)."""
    if isinstance(value, Container):
        return {k: plain(v) for k, v in value.items() if not k.startswith("_")}
    if isinstance(value, (list, ListContainer, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return f"<{len(value)} bytes>"
    if isinstance(value, Enum):
        return value.name
    if type(value).__name__ == "EnumIntegerString":
        return str(value)
    if isinstance(value, (bool, int, float, str)) or value is None:
        return value
    return str(value)


class RequestDecoder:
    """Cuts one connection's bytes into decoded requests (as the session does: an older robot
    client's, after its Connect, by its version's tables)."""

    def __init__(self, service: str) -> None:
        header, sizes, self._structs, _, _ = _TABLES[service]
        self._reader = FrameReader(header, sizes, 64 * 1024)
        self._broken = False
        self._service = service
        self.dialect = None  # an older robot client's (protocol/robot_v9.py), from its Connect

    def feed(self, data: bytes) -> list[dict]:
        if self._broken:
            return []
        try:
            frames = self._reader.feed(data)
        except ProtocolError as exc:
            self._broken = True
            return [{"malformed": str(exc)}]
        out = []
        for frame in frames:
            fields = plain(decode_request(frame, self._structs))
            fields.pop("header", None)
            out.append({"command": _name(frame.command, self._structs),
                        "command_id": frame.command_id, **fields})
            if out[-1]["command"] == "Connect" and self._service == "robot":
                self._older(fields.get("version"))
        return out

    def _older(self, version) -> None:
        """After a Connect: an older version's tables (a client waits for the Connect's reply
        before it sends more, so nothing after it was read by the old ones)."""
        make = DIALECTS.get(version)
        if make is not None and self.dialect is None:
            self.dialect = dialect = make()
            self._reader.retable(dialect.header, dialect.request_sizes)
            self._structs = dialect.request_structs


def decode_reply(service: str, data: bytes, dialect=None) -> dict:
    """A reply's command, id and status (and its other fields but large ones); `dialect`: the
    older protocol it was written in (RequestDecoder.dialect)."""
    header, _, _, responses, commands = _TABLES[service]
    try:
        head = header.parse(data[:header.sizeof()])
        if dialect is None:
            command = commands(int(head.command))
            struct = responses[command]
        else:
            command = dialect.commands(int.from_bytes(data[:4], "little"))
            struct = dialect.own_replies.get(command.name)
            if struct is None:
                data = dialect.unreply(data)
                struct = responses[commands[command.name]]
        fields = plain(struct.parse(data))
    except Exception as exc:  # noqa: BLE001 - a reply we cannot read is shown as such
        return {"unreadable": str(exc), "size": len(data)}
    fields.pop("header", None)
    return {"command": command.name, "command_id": int(head.command_id), **fields}


def _name(command: int, structs) -> str:
    for key in structs:
        if int(key) == command:
            return key.name
    return str(command)
