"""Sans-IO splitting of a TCP byte stream into whole command messages.

The endpoint feeds whatever ``recv`` returned and gets back complete frames; nothing here touches
a socket, so every chunking a kernel might produce can be tested in memory. The same reader
serves the robot (12-byte header) and the gripper (10-byte header): it only needs the header
struct and the fixed size of each known request.

Headers are checked as soon as they are complete, before the payload arrives, in this order:
size below the header length, size above ``max_size``, unknown command, size different from
the command's fixed size. A bad header means we no longer know where the next message starts,
so the reader cannot resynchronise: after raising, it stays failed (every later ``feed`` raises
the same error) and the caller must close the connection. Complete messages that came in the same
``feed`` call before the bad header are dropped with it; the connection is lost either way.
"""

from collections.abc import Mapping
from dataclasses import dataclass

from construct import Container, Struct

from .exceptions import (
    HeaderSizeTooSmallError,
    MessageSizeMismatchError,
    MessageTooLargeError,
    ProtocolError,
    UnknownCommandError,
)
from .robot_messages import REQUEST_STRUCTS

MAX_MESSAGE_SIZE = 64 * 1024  # far above any request (largest: 428 B), far below harm


@dataclass(frozen=True, slots=True)
class Frame:
    """One complete message: its header's command and id, and all of its bytes."""

    command: int
    command_id: int
    data: bytes


class FrameReader:
    """Accumulates stream bytes and cuts them into :class:`Frame` objects."""

    def __init__(
        self,
        header_struct: Struct,
        request_sizes: Mapping[int, int],
        max_size: int = MAX_MESSAGE_SIZE,
    ) -> None:
        self._header = header_struct
        self._header_size = header_struct.sizeof()
        self._sizes = {int(cmd): size for cmd, size in request_sizes.items()}
        self._max_size = max_size
        self._buffer = bytearray()
        self._error: ProtocolError | None = None

    @property
    def buffered(self) -> int:
        """Bytes of an incomplete message held back (non-zero at EOF means a torn message)."""
        return len(self._buffer)

    def feed(self, data: bytes, most: int | None = None) -> list[Frame]:
        """Add received bytes; return every message they complete, in order (at most `most`:
        the rest stays buffered, its headers unread)."""
        if self._error is not None:
            raise self._error
        buffer = self._buffer
        buffer += data
        frames: list[Frame] = []
        start = 0
        try:
            while len(buffer) - start >= self._header_size and (
                    most is None or len(frames) < most):
                header = self._header.parse(buffer[start : start + self._header_size])
                command, size = int(header.command), header.size
                self._check(command, size)
                if len(buffer) - start < size:
                    break
                message = bytes(buffer[start : start + size])
                frames.append(Frame(command, header.command_id, message))
                start += size
        except ProtocolError as error:
            self._error = error
            raise
        finally:
            del buffer[:start]
        return frames

    def retable(self, header_struct: Struct, request_sizes: Mapping[int, int]) -> None:
        """Cut what follows by another version's header and sizes (an older client's, from its
        Connect on); bytes already buffered are cut by them too."""
        self._header = header_struct
        self._header_size = header_struct.sizeof()
        self._sizes = {int(cmd): size for cmd, size in request_sizes.items()}

    def _check(self, command: int, size: int) -> None:
        if size < self._header_size:
            raise HeaderSizeTooSmallError(
                f"header size {size} is smaller than the {self._header_size}-byte header"
            )
        if size > self._max_size:
            raise MessageTooLargeError(f"header size {size} exceeds the limit {self._max_size}")
        expected = self._sizes.get(command)
        if expected is None:
            raise UnknownCommandError(f"unknown command {command}")
        if size != expected:
            raise MessageSizeMismatchError(
                f"command {command} has size {size}, expected {expected}"
            )


def decode_request(frame: Frame, structs: Mapping[int, Struct] = REQUEST_STRUCTS) -> Container:
    """Parse a frame with its command's request struct (pass the gripper table for 1338)."""
    try:
        struct = structs[frame.command]
    except KeyError:
        raise UnknownCommandError(f"unknown command {frame.command}") from None
    return struct.parse(frame.data)
