"""The robot's side of an end-effector tool: a sans-IO device clocked by the cycle number.

A tool (the Franka Hand: robot/hand.py) answers its own TCP service's requests (its session's
handler: `request`), says each cycle what its physical part does (`command`, handed to the
physics attachment: physics/tool.py), advances on what that part reads after the step
(`advance`), and has its replies and its state datagrams sent once the robot's state has left
(robot/arm_cycle.py). The arm's cycle knows nothing else of it; franka_sim/tools/ says which
device, physics, service and port make one tool.
"""

from __future__ import annotations

from typing import Protocol


class ToolDevice(Protocol):
    kind: str  # its tool's name (`--tool`, franka_sim/tools/): what the control API reports on

    @property
    def idle(self) -> bool:
        """No action runs (one a client may watch and stop: lockstep runs it on the wall
        clock, server/clock.py)."""

    @property
    def command(self) -> object | None:
        """What its physical part does in the next step (None: what it did)."""

    def advance(self, cycle: int, reading: object | None) -> None:
        """Cycle `cycle` was stepped and this is what its physical part read after it."""

    def take_replies(self) -> list[bytes]:
        """Answers to actions that completed, in order."""

    def skip(self, cycles: int) -> None:
        """The clock moved on `cycles` ids with no step (robot/fci.py `skip`): an action
        requested meanwhile starts after them."""

    def state_due(self, cycle: int) -> bool:
        """Whether cycle `cycle` sends its state datagram."""

    def pack_state(self, cycle: int) -> bytes:
        """Its state datagram for `cycle`."""

    def request(self, command, command_id: int, request) -> list[bytes]:
        """A decoded request of its service (robot/session.py); what is answered at once."""

    @property
    def busy(self) -> bool:
        """An action is under way whose client waits for its answer."""

    def reset(self, reading: object) -> None:
        """As the device starts, its physical part where `reading` has it."""

    def client_gone(self) -> None:
        """Its service's client closed the connection."""
