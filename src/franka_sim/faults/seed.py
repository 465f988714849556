"""The faults' seed: what the server's --seed and a POST /faults may name. Apart from the
plan, so that a server checks its --seed without importing the faults themselves."""

MAX_SEED = 2**64 - 1


def check_seed(seed) -> int:
    """A seed is an integer in [0, 2**64) (ValueError otherwise)."""
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be an integer in [0, 2**64), not {seed!r}")
    return seed
