"""`Control`: the control API from Python, on the standard library alone.

Its methods are made from the table of operations (control/table.py, itself standard library
only): one per row, taking the row's arguments (those of its path, then those of its JSON
body; an optional one left at None is not sent), so the client offers exactly what a server
serves. One HTTP request per call, each on its own connection (nothing to keep alive between a
test's calls, nothing shared between threads). A refusal raises the exception for its status
with the server's message (franka_sim.control.errors); no answer at all raises `Unreachable`.
"""

from __future__ import annotations

import http.client
import inspect
import json
import os
from collections.abc import Iterable
from urllib.parse import quote

from franka_sim.control.errors import ControlError, Unreachable, error_for, header_safe
from franka_sim.control.table import OPERATIONS, Operation

DEFAULT_PORT = 1340


def _jsonable(value):
    """What json cannot encode by itself: numpy arrays and numbers, paths, other sequences."""
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if hasattr(value, "tolist"):  # a numpy array or number: plain lists and numbers
        return value.tolist()
    if isinstance(value, Iterable) and not isinstance(value, (str, bytes, dict, set, frozenset)):
        return list(value)
    raise TypeError(f"{value!r} cannot be sent as JSON")


class Control:
    """The control API of the simulator at `host` (its robot's address) and `port`.

    `token`: the server's --control-token, if it has one. `timeout`: seconds to wait for a
    connection and for each answer.
    """

    def __init__(self, host: str, port: int = DEFAULT_PORT, token: str | None = None,
                 timeout: float = 5.0) -> None:
        self.host, self.port, self.timeout = host, port, timeout
        self._headers = {"Accept": "application/json"}
        if token is not None:
            if not isinstance(token, str) or not header_safe(token):
                raise ValueError(f"token must be the server's --control-token (printable text, "
                                 f"no leading or trailing space), not {token!r}")
            # (as UTF-8, as the server reads it: http.client would send Latin-1)
            self._headers["Authorization"] = b"Bearer " + token.encode()

    def __repr__(self) -> str:
        return f"Control({self.host!r}, {self.port})"

    # -- HTTP ------------------------------------------------------------------------------------
    def _operation(self, operation: Operation, arguments: dict):
        """One row's request: its path with the path's arguments put in, a JSON body of the
        others given (when the row takes a body), the answer unwrapped as the row says."""
        path = operation.where(**{name: quote(str(arguments[name]), safe="/")
                                  for name in operation.path_args})
        body = None
        if operation.body:
            body = {arg.name: arguments[arg.name] for arg in operation.body
                    if arguments[arg.name] is not None}
        answer = self._call(operation.method, path, body)
        return answer[operation.answer_key] if operation.answer_key is not None else answer

    def _call(self, method: str, path: str, body: dict | None = None):
        headers = dict(self._headers)
        payload = None
        if body is not None:
            payload = json.dumps(body, default=_jsonable).encode()
            headers["Content-Type"] = "application/json"
        connection = http.client.HTTPConnection(self.host, self.port, timeout=self.timeout)
        try:
            connection.request(method, path, payload, headers)
            response = connection.getresponse()
            status, text = response.status, response.read().decode("utf-8", "replace")
        except (OSError, http.client.HTTPException) as exc:
            raise Unreachable(f"{self.host}:{self.port}: {str(exc) or type(exc).__name__}") from None
        finally:
            connection.close()
        try:
            answer = json.loads(text)
        except ValueError:
            answer = None
        if status >= 400:
            message = answer.get("error") if isinstance(answer, dict) else None
            raise error_for(status, message or text.strip() or f"HTTP {status}")
        if answer is None:
            raise ControlError(f"{method} {path}: the answer is not JSON: {text[:200]!r}", status)
        return answer


def _method(operation: Operation):
    """Control's method for a row: the row's arguments, its doc."""
    parameters = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    for arg in operation.arguments:
        default = inspect.Parameter.empty if arg.required else arg.default
        parameters.append(inspect.Parameter(
            arg.name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=default))
    signature = inspect.Signature(parameters)

    def method(self, *args, **kwargs):
        bound = signature.bind(self, *args, **kwargs)  # TypeError: not the row's arguments
        bound.apply_defaults()
        arguments = dict(bound.arguments)
        del arguments["self"]
        return self._operation(operation, arguments)

    method.__name__ = operation.name
    method.__qualname__ = f"Control.{operation.name}"
    method.__doc__ = operation.doc
    method.__signature__ = signature
    return method


for _operation in OPERATIONS:
    setattr(Control, _operation.name, _method(_operation))
del _operation
