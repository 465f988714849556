"""The older robot protocol versions served beside v10, by version: each one's Dialect
(protocol_specs/robot_v9.md, robot_v5.md). The session picks one at Connect; a recording's
reader reads that client's bytes with it too.

A version's module is imported when its Dialect is first asked for: only an older client's
Connect asks, and a server that never meets one keeps them (~0.2 MiB) out of memory."""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping

# Each module's own VERSION is its key here (tests/protocol check it).
MODULES = {9: "robot_v9", 8: "robot_v8", 7: "robot_v7", 6: "robot_v6", 5: "robot_v5"}


class _Dialects(Mapping):
    """version → that version's Dialect class, imported on first use."""

    def __getitem__(self, version: int) -> type:
        module = importlib.import_module(f"{__package__}.{MODULES[version]}")
        return module.Dialect

    def __iter__(self) -> Iterator[int]:
        return iter(MODULES)

    def __len__(self) -> int:
        return len(MODULES)


DIALECTS = _Dialects()
