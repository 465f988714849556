"""A request body that must be one JSON object: the control API's and the Desk's, each of
which turns the reason into its own refusal (HTTP 400 with the reason)."""

from __future__ import annotations

import json

# What a JSON value is called, by the type Python decodes it to (in the reason a body that is
# not an object is refused with: "a JSON object, not an array").
_KINDS = {list: "an array", str: "a string", bool: "true or false", int: "a number",
          float: "a number", type(None): "null"}


def _no_constants(name: str) -> float:
    raise ValueError(f"{name} is not a JSON number")


def _integer(text: str) -> int:
    """An integer as json reads it; past the 4300 digits Python reads, a reason of ours (its
    own names an interpreter setting)."""
    digits = len(text.lstrip("-"))
    if digits > 4300:
        raise ValueError(f"a number of {digits} digits, past any figure a call takes")
    return int(text)


def json_object(raw: bytes, *, optional: bool = False) -> dict:
    """The body's JSON object ({} for an empty `optional` one); ValueError says why not:
    empty, malformed (NaN and Infinity too: no JSON numbers), nested too deeply, or another
    kind of value."""
    if not raw.strip():
        if optional:
            return {}
        raise ValueError("expected a JSON object in the request body")
    try:
        value = json.loads(raw.decode("utf-8"), parse_constant=_no_constants,
                           parse_int=_integer)
    except (UnicodeDecodeError, ValueError) as exc:  # JSONDecodeError is a ValueError
        raise ValueError(f"malformed JSON: {exc}") from None
    except RecursionError:
        raise ValueError("malformed JSON: nested too deeply") from None
    if not isinstance(value, dict):
        raise ValueError(f"expected a JSON object, not {_KINDS.get(type(value), 'that')}")
    return value
