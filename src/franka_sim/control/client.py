"""`Control`: the control API from Python, on the standard library alone.

One HTTP request per call, each on its own connection (nothing to keep alive between a test's
calls, nothing shared between threads). A refusal raises the exception for its status with the
server's message (franka_sim.control.errors); no answer at all raises `Unreachable`.
"""

from __future__ import annotations

import http.client
import json
import os
from collections.abc import Iterable
from urllib.parse import quote

from franka_sim.control.errors import ControlError, Unreachable, error_for

DEFAULT_PORT = 1340


def _numbers(values: Iterable) -> list[float]:
    """A JSON list from any sequence of numbers (numpy arrays included)."""
    return [float(v) for v in values]


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
            self._headers["Authorization"] = f"Bearer {token}"

    def __repr__(self) -> str:
        return f"Control({self.host!r}, {self.port})"

    # -- resources -------------------------------------------------------------------------------
    def health(self) -> dict:
        """{"ready", "clock", "cycle", "client_connected", "robot_mode"}: cheap, for probes.
        Failed (503) once the simulator stopped simulating, with the reason."""
        return self._call("GET", "/health")

    def state(self) -> dict:
        """The ground truth now: q, dq, tau_J, O_T_EE (4×4, rows), robot_mode, errors (names),
        success_rate, gripper_width (None without a Hand), cycle."""
        return self._call("GET", "/state")

    def reset(self, q=None, gripper_width: float | None = None) -> dict:
        """Arm at rest at q (None: the start pose), errors cleared, Idle, objects back where they
        started, Hand open (or `gripper_width` apart). Conflict while a motion runs."""
        body: dict = {}
        if q is not None:
            body["q"] = _numbers(q)
        if gripper_width is not None:
            body["gripper_width"] = float(gripper_width)
        return self._call("POST", "/reset", body)

    def bodies(self) -> list[dict]:
        """The world's bodies: [{"name", "free"}], a free body being one `set_pose` can move."""
        return self._call("GET", "/bodies")["bodies"]

    def pose(self, name: str) -> dict:
        """{"position", "quaternion" (w, x, y, z), "linear_velocity", "angular_velocity",
        "free"} of a body, in the world (= the robot's base) frame."""
        return self._call("GET", "/bodies/" + quote(name, safe="/"))

    def set_pose(self, name: str, position, quaternion=None) -> dict:
        """Put a free body at `position`, turned to `quaternion` (w, x, y, z; None: as it is), at
        rest. Returns its pose."""
        body: dict = {"position": _numbers(position)}
        if quaternion is not None:
            body["quaternion"] = _numbers(quaternion)
        return self._call("PUT", "/bodies/" + quote(name, safe="/"), body)

    def push(self, body: str, force, torque=None, duration: float = 0.1) -> dict:
        """Push `body` with `force` (N) and `torque` (Nm), base frame, at its centre of mass,
        for `duration` seconds of simulated time."""
        request: dict = {"body": body, "force": _numbers(force), "duration": float(duration)}
        if torque is not None:
            request["torque"] = _numbers(torque)
        return self._call("POST", "/push", request)

    def start_recording(self, path) -> dict:
        """Reset the world (as `reset()`) and record everything from there into `path`, an
        MCAP file on the server's machine (relative: to the server's working directory).
        Returns {"path", "cycle"}. Conflict while a recording runs or a client is connected."""
        return self._call("POST", "/recording", {"path": os.fspath(path)})

    def finish_recording(self) -> dict:
        """End the recording `start_recording` began; once this returns the file is complete.
        Returns {"path", "cycle", "dropped"} (events the recorder could not keep up with)."""
        return self._call("DELETE", "/recording")

    def faults(self) -> dict:
        """The network faults injected on this arm's UDP path: {"spec", "fields", "seed",
        "states", "commands"}, the last two counting what was seen, dropped, delayed,
        reordered and is held now."""
        return self._call("GET", "/faults")

    def set_faults(self, spec: str | None = None, *, seed: int | None = None,
                   **fields) -> dict:
        """Inject faults from the next datagram on: a spec ("loss=0.01,delay=2ms") or its
        fields (loss=0.01, delay="2ms", burst="25@3s", reorder=..., dir="commands");
        `seed`: the server's --seed when None. Returns what GET /faults does."""
        body: dict = dict(fields)
        if spec is not None:
            body["spec"] = spec  # (with fields too: refused, one or the other)
        if seed is not None:
            body["seed"] = int(seed)
        return self._call("POST", "/faults", body)

    def clear_faults(self) -> dict:
        """Inject nothing more; returns what the faults did."""
        return self._call("DELETE", "/faults")

    # -- HTTP --------------------------------------------------------------------------------------
    def _call(self, method: str, path: str, body: dict | None = None):
        headers = dict(self._headers)
        payload = None
        if body is not None:
            payload = json.dumps(body).encode()
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
