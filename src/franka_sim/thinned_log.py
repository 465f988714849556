"""How often a repeated event is logged: the 1st, 10th, 100th and every 1000th time.

A misbehaving client can repeat the same mistake a thousand times a second; the log shows that
it happens and how often, without being flooded by it.
"""


def worth_logging(count: int) -> bool:
    """True for the occurrences (counted from 1) that get a log line."""
    return count in (1, 10, 100) or count % 1000 == 0
