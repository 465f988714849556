"""Recording a run to MCAP, and what reads one back: replay, plot, render.

`recorder.py` taps the server (a bounded queue the cycle thread only appends to) and
`writer.py` drains it on a thread of its own; `channels.py` names what is recorded and how it is
encoded; `reader.py` opens a recording and says in one line why it cannot.
"""

FORMAT_VERSION = 2  # bumped when a reader of the previous format would misread a new file

MCAP_HINT = "recording needs the mcap package: pip install 'franka-sim[record]'"


def mcap_missing() -> str | None:
    """None when recordings can be written and read; else the one line that says what to
    install (mcap is an extra: a server that records nothing never needs it)."""
    try:
        import mcap  # noqa: F401
    except ImportError:
        return MCAP_HINT
    return None
