"""Typed failures of the wire layer, one per thing a caller can act on.

All derive from :class:`ProtocolError` (a ``ValueError``: the peer sent bytes that are not a valid
message), so an endpoint can close a connection on the base class and still log the precise cause.
"""


class ProtocolError(ValueError):
    """Bytes from a peer that do not form a valid message of this protocol."""


class HeaderSizeTooSmallError(ProtocolError):
    """A TCP header claims a total size smaller than the header itself."""


class MessageTooLargeError(ProtocolError):
    """A TCP header claims a size above the reader's limit (protects our memory)."""


class UnknownCommandError(ProtocolError):
    """A TCP header names a command this protocol version does not have."""


class MessageSizeMismatchError(ProtocolError):
    """A known TCP command arrives with a size different from its fixed size."""


class DatagramSizeError(ProtocolError):
    """A UDP datagram is not exactly the size of the struct it must carry."""
