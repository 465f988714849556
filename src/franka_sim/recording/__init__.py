"""A recording's format: what a run's MCAP file holds and how it is read back.

`channels.py` names what is recorded and how it is encoded; `metadata.py` is the configuration
record replay builds the same world from; `reader.py` opens a recording and says in one line why
it cannot; `wire_json.py` turns TCP bytes into JSON for the file's readers. The live writer is
the server's (server/recorder/); what is done with a file is franka_sim/playback/.
"""

FORMAT_VERSION = 2  # bumped when a reader of the previous format would misread a new file

MCAP_HINT = "recording needs the mcap package: pip install 'franka-sim[record]'"


def mcap_missing(extra: str = "record") -> str | None:
    """None when recordings can be written and read; else the one line that says what to
    install (mcap is an extra: a server that records nothing never needs it). `extra`: the one
    the command needs, which brings mcap with it (plot, render, web)."""
    try:
        import mcap  # noqa: F401
    except ImportError:
        return MCAP_HINT.replace("[record]", f"[{extra}]")
    return None


def being_written(stream) -> bool:
    """Whether a server records to this open file now: its writer holds an exclusive lock on
    it (server/recorder/writer.py) for as long as it records."""
    import fcntl

    try:
        fcntl.flock(stream.fileno(), fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:  # a file system without locks: nothing can be told
        return False
    fcntl.flock(stream.fileno(), fcntl.LOCK_UN)
    return False
