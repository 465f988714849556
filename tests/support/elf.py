"""What a model library served to an older client is, read from its ELF header."""

from __future__ import annotations

import struct

ELF_MACHINES = {0x3E: "x86_64", 0xB7: "aarch64"}  # e_machine: EM_X86_64, EM_AARCH64


def elf_machine(library: bytes) -> str | None:
    """The architecture of a 64-bit little-endian ELF shared object; None if it is none."""
    if library[:6] != b"\x7fELF\x02\x01" or len(library) < 20:
        return None
    e_type, e_machine = struct.unpack_from("<HH", library, 16)
    return ELF_MACHINES.get(e_machine, hex(e_machine)) if e_type == 3 else None  # ET_DYN
