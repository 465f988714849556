"""The Franka Hand's actions (robot/hand.py), each a ramp of the opening clocked by the cycle
number: Move, Grasp and Homing say what the finger drive does each cycle and, given the
fingers' reading, when they are done and how they answer."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

from franka_sim.physics.fingers import FingerCommand, FingerState
from franka_sim.protocol.enums import GripperCommand, GripperStatus
from franka_sim.protocol.timing import CYCLE_PERIOD as DT

log = logging.getLogger("franka_sim.robot.hand")

STATE_PERIOD = 100  # cycles between GripperStates: 10 Hz
NOMINAL_MAX_WIDTH = 0.08  # m, the datasheet opening: max_width until a homing measures it
MAX_SPEED = 0.1  # m/s of opening
MIN_SPEED = 1e-3  # m/s: slower requests are refused, so none blocks its client for long
HOMING_SPEED = 0.1  # m/s of opening
HOMING_OPEN_TARGET = 0.1  # m: beyond any stop, so the fingers open until they are stopped
HOMING_FORCE = 10.0  # N per finger against the stops
MAX_FORCE = 100.0  # N per finger: the drive's limit (physics/fingers.py), also a Move's force
MOVE_TOLERANCE = 5e-4  # m: a Move has arrived within this of its goal
MOVE_TIMEOUT = 500  # cycles after its ramp a blocked Move gives up
SETTLE_TIMEOUT = 1000  # cycles after a ramp: fingers still not at rest count as stopped
BLOCKED_LAG = 2e-3  # m: fingers this far behind their ramp are stopped by something
SQUEEZE_CYCLES = 50  # cycles a grasp squeezes before it judges the width
AT_REST_SPEED = 1e-3  # m/s
STOP_CLEARANCE = 8e-6  # m of opening: a homed Hand holds at most max_width less this
TEMPERATURE = 30  # °C, constant (no thermal model)



def finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


@dataclass
class Ramp:
    """The opening going from `start` to `goal` at `speed`, one step per cycle from `first`."""

    first: int
    start: float
    goal: float
    speed: float

    def at(self, cycle: int) -> tuple[float, float]:
        """(target opening, its rate) commanded for `cycle`."""
        distance = abs(self.goal - self.start)
        travel = self.speed * DT * (cycle - self.first + 1)
        if travel >= distance:
            return self.goal, 0.0
        sign = 1.0 if self.goal > self.start else -1.0
        return self.start + sign * travel, sign * self.speed

    def done(self, cycle: int) -> bool:
        return self.at(cycle)[1] == 0.0

    def overdue(self, cycle: int) -> bool:
        """Ended SETTLE_TIMEOUT cycles ago: stop waiting for the fingers to come to rest."""
        steps = math.ceil(abs(self.goal - self.start) / (self.speed * DT))
        return cycle - self.first >= steps + SETTLE_TIMEOUT


class Move:
    kind = GripperCommand.Move

    def __init__(self, command_id: int, first: int, width: float, goal: float, speed: float):
        self.command_id = command_id
        self.ramp = Ramp(first, width, goal, speed)
        self.ended: int | None = None  # cycle the ramp reached the goal

    def command(self, cycle: int) -> FingerCommand:
        return FingerCommand(*self.ramp.at(cycle), MAX_FORCE)

    def update(self, cycle: int, fingers: FingerState) -> GripperStatus | None:
        if not self.ramp.done(cycle):
            return None
        if self.ended is None:
            self.ended = cycle
        if abs(fingers.width - self.ramp.goal) <= MOVE_TOLERANCE:
            return GripperStatus.kSuccess
        if cycle - self.ended >= MOVE_TIMEOUT:
            log.info("gripper Move to %.4f m blocked at %.4f m", self.ramp.goal, fingers.width)
            return GripperStatus.kUnsuccessful
        return None


@dataclass(frozen=True)
class GraspArgs:
    width: float
    epsilon_inner: float
    epsilon_outer: float
    speed: float
    force: float

    def holds(self, d: float) -> bool:
        """libfranka's grasp rule: width − ε_inner < d < width + ε_outer."""
        return self.width - self.epsilon_inner < d < self.width + self.epsilon_outer


class Grasp:
    kind = GripperCommand.Grasp

    def __init__(self, command_id: int, first: int, width: float, request: GraspArgs):
        self.command_id = command_id
        self.args = request
        self.ramp = Ramp(first, width, 0.0, request.speed)
        self.squeezing_since: int | None = None

    def command(self, cycle: int) -> FingerCommand:
        if self.squeezing_since is None:
            return FingerCommand(*self.ramp.at(cycle), self.args.force)
        return FingerCommand(0.0, 0.0, self.args.force)

    def update(self, cycle: int, fingers: FingerState) -> GripperStatus | None:
        if self.squeezing_since is None:
            target = self.ramp.at(cycle)[0]
            closed = self.ramp.done(cycle) and abs(fingers.speed) < AT_REST_SPEED
            if fingers.width - target > BLOCKED_LAG or closed or self.ramp.overdue(cycle):
                self.squeezing_since = cycle
            return None
        if cycle - self.squeezing_since < SQUEEZE_CYCLES:
            return None
        if self.args.holds(fingers.width):
            return GripperStatus.kSuccess
        return GripperStatus.kUnsuccessful


class Homing:
    kind = GripperCommand.Homing

    def __init__(self, command_id: int, first: int, width: float):
        self.command_id = command_id
        self.ramp = Ramp(first, width, 0.0, HOMING_SPEED)
        self.opening = False
        self.max_width: float | None = None

    def command(self, cycle: int) -> FingerCommand:
        target, rate = self.ramp.at(cycle)
        return FingerCommand(target, rate, HOMING_FORCE if self.opening else MAX_FORCE)

    def update(self, cycle: int, fingers: FingerState) -> GripperStatus | None:
        target = self.ramp.at(cycle)[0]
        lag = abs(fingers.width - target)
        stopped = abs(fingers.speed) < AT_REST_SPEED or self.ramp.overdue(cycle)
        if not self.opening:
            if (self.ramp.done(cycle) or lag > BLOCKED_LAG) and stopped:
                self.opening = True
                self.ramp = Ramp(cycle + 1, fingers.width, HOMING_OPEN_TARGET, HOMING_SPEED)
            return None
        if (lag > BLOCKED_LAG or self.ramp.done(cycle)) and stopped:
            self.max_width = fingers.width
            return GripperStatus.kSuccess
        return None
