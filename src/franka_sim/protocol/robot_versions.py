"""The older robot protocol versions served beside v10, by version: each one's Dialect
(protocol_specs/robot_v9.md, robot_v5.md). The session picks one at Connect; a recording's
reader reads that client's bytes with it too."""

from __future__ import annotations

from . import robot_v5, robot_v6, robot_v7, robot_v8, robot_v9

DIALECTS = {v.VERSION: v.Dialect for v in (robot_v5, robot_v6, robot_v7, robot_v8, robot_v9)}
