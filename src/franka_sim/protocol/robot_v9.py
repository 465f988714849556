"""Robot protocol v9 (libfranka 0.15 to 0.17), as it differs from v10.

The robot's own tables are v10's (robot_messages.py, robot_state.py, robot_command.py); a v9
client is served through this module's Dialect, which reads its requests as v10's (the same
names) and writes v10's replies and states as v9's. What differs, restated from
libfranka-common's service_types.h and rbk_types.h at the commit that made the version 9:
- command ids: LoadModelLibrary is 11 and GetRobotModel 12 (v10 has no LoadModelLibrary, and
  GetRobotModel is 11);
- a Move request has no async generator fields (use_async_motion_generator, maximum_velocity);
- LoadModelLibrary asks for the robot's kinematics as a shared library for the client's
  architecture and system, and is answered with a status and the library's bytes;
- the RobotState's numbers are float64, without the accelerometers (2373 bytes).
The RobotCommand datagram is the same. The URDF GetRobotModel serves has no accelerometer
links either (they came with v10): libfranka 0.14–0.17 attach the end effector's load to the
frame its URDF parser puts last, which with them would be one of link0's, not the flange.
"""

from __future__ import annotations

import logging
from enum import IntEnum
from xml.etree import ElementTree

import numpy as np
from construct import Array, Enum, Float32l, Float64l, GreedyBytes, Int8ul, Struct

from . import robot_messages as rm
from . import robot_state as rs
from .codec import STATE_DTYPE
from .enums import Command as V10Command
from .message import build_message, command_header, message, renumbered

VERSION = 9
log = logging.getLogger(__name__)


# Robot TCP command ids of v9 (uint32 on the wire): v10's up to AutomaticErrorRecovery, then
# LoadModelLibrary 11 and GetRobotModel 12.
Command = IntEnum("Command", [*((c.name, c.value) for c in V10Command
                                if c is not V10Command.GetRobotModel),
                              ("LoadModelLibrary", 11), ("GetRobotModel", 12)], module=__name__)


class Architecture(IntEnum):
    kX64 = 0
    kX86 = 1
    kARM = 2
    kARM64 = 3


class System(IntEnum):
    kLinux = 0
    kWindows = 1


class LoadModelLibraryStatus(IntEnum):
    kSuccess = 0
    kError = 1


CommandHeader = command_header(Command)


def _payload(struct: Struct) -> list:
    """The payload fields of a v10 message (all but its header)."""
    return list(struct.subcons[1:])


MoveRequest = message(CommandHeader, *[f for f in _payload(rm.MoveRequest)
                                        if f.name not in ("use_async_motion_generator",
                                                          "maximum_velocity")])
LoadModelLibraryRequest = message(
    CommandHeader, "architecture" / Enum(Int8ul, Architecture), "system" / Enum(Int8ul, System))
LoadModelLibraryResponse = message(
    CommandHeader, "status" / Enum(Int8ul, LoadModelLibraryStatus),
    "library" / GreedyBytes)  # no length prefix: the header size delimits it

REQUEST_STRUCTS: dict = renumbered(rm.REQUEST_STRUCTS, Command, CommandHeader)
REQUEST_STRUCTS[Command.Move] = MoveRequest
REQUEST_STRUCTS[Command.LoadModelLibrary] = LoadModelLibraryRequest
REQUEST_SIZES: dict[Command, int] = {c: s.sizeof() for c, s in REQUEST_STRUCTS.items()}
GetRobotModelRequest = REQUEST_STRUCTS[Command.GetRobotModel]  # (its id is 12 in v9)


def _widened(field):
    """A v10 state field as v9 has it: float32 numbers as float64, the rest as they are."""
    sub = field.subcon
    if sub is Float32l:
        return field.name / Float64l
    if isinstance(sub, Array) and sub.subcon is Float32l:
        return field.name / Array(sub.count, Float64l)
    return field


# v9's RobotState: v10's fields but the accelerometers, every number float64.
RobotState = Struct(*[_widened(f) for f in rs.RobotState.subcons
                      if not f.name.startswith("accelerometer")])
ROBOT_STATE_SIZE = 2373
assert RobotState.sizeof() == ROBOT_STATE_SIZE, RobotState.sizeof()

# The v10 state's bytes, by what v9 does with them (offsets read off both layouts).
_V10 = STATE_DTYPE.fields
_FLOATS = (_V10["O_T_EE"][1] - 8) // 4 + (_V10["accelerometer_top"][1] - _V10["O_T_EE"][1]) // 4
_MODES_V10 = _V10["motion_generator_mode"][1]  # modes, errors, reflex_reason, robot_mode
_RATE_V10 = _V10["control_command_success_rate"][1]
_MODES_LEN = _RATE_V10 - _MODES_V10
_MODES_V9 = 8 + 8 * _FLOATS
assert _MODES_V9 + _MODES_LEN + 8 == ROBOT_STATE_SIZE
# v10's reply command ids as v9 numbers them (by name).
_REPLY_IDS = {int(c): int(Command[c.name]) for c in V10Command}


def urdf_without_accelerometers(urdf: bytes) -> bytes:
    """The URDF without its accelerometer links and the joints that hold them."""
    root = ElementTree.fromstring(urdf)
    for element in list(root):
        if element.tag in ("link", "joint") and "accelerometer" in element.get("name", ""):
            root.remove(element)
    return ElementTree.tostring(root, encoding="utf-8", xml_declaration=True)


class Dialect:
    """How the v10 robot serves a v9 client (robot/session.py picks it at Connect). Versions 7
    and 8 are v9 with another number, and 7 without GetRobotModel (robot_v7.py, robot_v8.py):
    each is this class with its own tables."""

    version = VERSION
    commands = Command
    header = CommandHeader
    request_sizes = REQUEST_SIZES
    request_structs = REQUEST_STRUCTS

    def __init__(self) -> None:
        self._out = bytearray(ROBOT_STATE_SIZE)
        self._floats = np.ndarray(_FLOATS, "<f8", buffer=self._out, offset=8)
        self._rate = np.ndarray(1, "<f8", buffer=self._out, offset=_MODES_V9 + _MODES_LEN)

    def request(self, command: int, request):
        """A decoded request as v10 names it (Move with the async fields at their defaults);
        a request v10 has no equivalent of keeps its own version's Command."""
        older = self.commands(command)
        if older.name == "Move":
            request.use_async_motion_generator = False
            request.maximum_velocity = [0.0] * 7
        return V10Command.__members__.get(older.name, older), request

    def reply(self, data: bytes) -> bytes:
        """A v10 reply with its header's command id as v9 numbers it (GetRobotModel's URDF as
        a v9 robot has it)."""
        v10 = int.from_bytes(data[:4], "little")
        if v10 == V10Command.GetRobotModel:
            parsed = rm.GetRobotModelResponse.parse(data)
            return build_message(rm.GetRobotModelResponse, Command.GetRobotModel,
                                 parsed.header.command_id,
                                 {"status": parsed.status,
                                  "urdf": urdf_without_accelerometers(parsed.urdf)})
        v9 = _REPLY_IDS[v10]
        return data if v9 == v10 else v9.to_bytes(4, "little") + data[4:]

    # How the client's RobotCommand datagrams read as v10's (None: they are v10's).
    command = None
    # The replies of this version v10 has no equivalent of, by command name: their layouts
    # (the recording's reader decodes them; `unreply` turns the others back into v10's).
    own_replies = {"LoadModelLibrary": LoadModelLibraryResponse}

    def unreply(self, data: bytes) -> bytes:
        """A reply this version wrote, as v10 wrote it (`reply` undone; not own_replies')."""
        v10 = V10Command[self.commands(int.from_bytes(data[:4], "little")).name]
        return int(v10).to_bytes(4, "little") + data[4:]

    def answer(self, command, command_id: int, request, library) -> bytes:
        """The reply to a request the v10 robot has no equivalent of: LoadModelLibrary's, the
        library (`library(request)`: None, or no provider, is kError)."""
        made = None if library is None else library(request)
        if made is None:
            fields = {"status": LoadModelLibraryStatus.kError, "library": b""}
        else:
            log.info("model library sent to the robot client (%d bytes)", len(made))
            fields = {"status": LoadModelLibraryStatus.kSuccess, "library": made}
        return build_message(LoadModelLibraryResponse, self.commands.LoadModelLibrary,
                             command_id, fields)

    def state(self, data: bytes) -> bytes:
        """A v10 RobotState as v9 sends it: each number widened to float64 (its value is the
        float32 the v10 state holds), the accelerometers left out."""
        out = self._out
        out[:8] = data[:8]
        self._floats[:] = np.frombuffer(data, "<f4", _FLOATS, 8)
        out[_MODES_V9:_MODES_V9 + _MODES_LEN] = data[_MODES_V10:_RATE_V10]
        self._rate[0] = np.frombuffer(data, "<f4", 1, _RATE_V10)[0]
        return bytes(out)
