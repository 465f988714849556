"""How the serving process writes its log: one line per record, whatever a client put in it.

Messages quote what clients send (a path, a body's name, a Desk user): a newline in it would
start a line that reads as the server's own, an escape sequence would clear the terminal of
whoever reads the log. So control characters are written escaped (`\\n`, `\\x1b`); a traceback
still follows its line as Python writes it."""

from __future__ import annotations

import logging

FORMAT = "%(asctime)s %(levelname)s %(name)s: %(robot)s%(message)s"

_ESCAPED = {code: f"\\x{code:02x}" for code in (*range(32), *range(127, 160))}
_ESCAPED.update({ord("\n"): "\\n", ord("\r"): "\\r", ord("\t"): "\t"})  # (a tab stays)


class OneLine(logging.Formatter):
    """FORMAT, the message's control characters escaped. `clear_line`: each record first
    clears the terminal's line, where `serve`'s status line (server/status_line.py) stands
    without its newline: the record then does not run on from it."""

    def __init__(self, fmt: str = FORMAT, *, clear_line: bool = False) -> None:
        super().__init__(fmt)
        self._prefix = "\r\x1b[K" if clear_line else ""

    def formatMessage(self, record: logging.LogRecord) -> str:  # noqa: N802 - logging's name
        record.message = record.message.translate(_ESCAPED)
        return self._prefix + super().formatMessage(record)

