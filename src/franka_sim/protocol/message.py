"""Shape shared by every TCP message of both protocols: a header, then the command's payload.

The header's ``size`` counts the whole message including the header, so it is only known once
the payload is built; :func:`build_message` fills it in, which is why no caller ever passes it.
"""

from enum import IntEnum
from typing import Any

from construct import Enum, Int32ul, Struct, Subconstruct


def command_header(commands: type[IntEnum]) -> Struct:
    """The robot protocol's header, its command ids numbered as `commands` (one per version)."""
    return Struct(
        "command" / Enum(Int32ul, commands),
        "command_id" / Int32ul,
        "size" / Int32ul,  # whole message, header included
    )


def renumbered(structs: dict, commands: type[IntEnum], header: Struct) -> dict:
    """Another version's request layouts under `commands`' ids and `header`: those of the
    commands it has (by name)."""
    return {commands[c.name]: message(header, *s.subcons[1:])
            for c, s in structs.items() if c.name in commands.__members__}


def message(header: Struct, *payload: Subconstruct) -> Struct:
    """Declare a message as ``header`` followed by the named payload fields."""
    return Struct("header" / header, *payload)


def build_message(struct: Struct, command: int, command_id: int, fields: dict[str, Any]) -> bytes:
    """Build ``struct`` with a header whose size matches the built bytes.

    Built twice (first with size 0) so variable-length payloads such as the URDF need no
    special case; TCP commands are rare, so the second build costs nothing that matters.
    """
    header = {"command": command, "command_id": command_id, "size": 0}
    header["size"] = len(struct.build({"header": header, **fields}))
    return struct.build({"header": header, **fields})
