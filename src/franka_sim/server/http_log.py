"""What aiohttp logs about the requests it refuses itself, as one line each.

Before a request reaches the control API's or the Desk's handlers, aiohttp's own parser may
refuse it (a malformed Content-Length or chunk, a line or header over its limits, a method it
does not know) and answers 400 in plain text; it logs each refusal as an error with a
traceback of its parser (an unknown method at debug level), and so does a handler whose
client hung up mid-body. Neither is the server's error: each becomes one warning naming what
was wrong and who sent it. A body whose Content-Encoding does not decode is refused by the
handler, which says so; aiohttp's own traceback of it, as it drains the rest, is dropped."""

from __future__ import annotations

import logging

from aiohttp.web_protocol import RequestPayloadError


class _OneLine(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        if exc is None:
            return _shown(record)
        if isinstance(exc, RequestPayloadError):
            return False  # a body that does not decode: the handler refused it (its one line)
        if isinstance(exc, ConnectionError):
            said = "the client left before its request was whole"
        elif isinstance(getattr(exc, "code", None), int) and hasattr(exc, "message"):
            lines = [line.strip() for line in str(exc.message).splitlines() if line.strip()]
            said = f"refused ({exc.code}): {' '.join(lines[:2]).rstrip(':')}"
        else:  # a fault of ours: the traceback stays
            return _shown(record)
        peer = record.getMessage().rpartition(" from ")[2] if " from " in record.msg else "?"
        record.msg, record.args = "HTTP request from %s %s", (peer, said)
        record.exc_info, record.exc_text = None, None
        record.levelno, record.levelname = logging.WARNING, "WARNING"
        return _shown(record)


def _shown(record: logging.LogRecord) -> bool:
    """At the level the server logs at (the logger itself lets debug through: see below)."""
    return record.levelno >= logging.getLogger().getEffectiveLevel()


_installed = False


def quiet_aiohttp() -> None:
    """Install the filter on aiohttp's server logger (once per process). aiohttp logs a
    connection's first request with an unknown method (not HTTP at all, or TLS on a plain
    port) at debug level: the logger passes debug on, for the filter to make it a warning."""
    global _installed
    if not _installed:
        logger = logging.getLogger("aiohttp.server")
        logger.addFilter(_OneLine())
        if logger.getEffectiveLevel() > logging.DEBUG:
            logger.setLevel(logging.DEBUG)
        _installed = True
