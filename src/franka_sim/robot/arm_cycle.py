"""An arm's part of a world cycle, sans-IO (the contract: robot/cycle.py).

`drive` has the core close the open command window and say what the joint drives do, and gives
the arm's body that command (with its tool's command) for the world's next step;
`publish`, once the world stepped, takes the desired-side kinematics at q_d when a generator
sets it, and has the core pack the RobotState; `complete`, after the state has left, advances
the tool (robot/tool.py) on its new reading, does the part of the physics step that no reading needed,
runs the log-only limit checks and hands back the replies the cycle produced (robot and tool).

Work that a client does not wait for comes after the send, so a lockstep client gets its state
as early as possible; doing it later gives the same bits (physics/world.py, "Step structure").
"""

from __future__ import annotations

import logging

from franka_sim.physics.backend import Backend
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.cycle import NO_REPLIES, PacerQuestions, Released, Replies
from franka_sim.robot.tool import ToolDevice
from franka_sim.thinned_log import worth_logging

log = logging.getLogger(__name__)

GIVE_UP_AFTER = 1000  # cycles in a row (1 s) whose state could not be published


class ArmCycle(PacerQuestions):
    def __init__(self, core: ArmCore, physics: Backend, tool: ToolDevice | None = None, *,
                 tool_state_wanted=lambda: True) -> None:
        self.core = core
        self.physics = physics
        self.tool = tool  # its tool's device (robot/tool.py), or None
        self.tool_state_wanted = tool_state_wanted  # () -> bool: a tool client takes states
        self._failures = 0
        self._failing = 0  # cycles in a row whose state could not be published
        self._measured = None  # the last step's measurement
        self._unchanged = False  # the last step handed back the one before (physics at rest)
        self._q_d = None  # the desired q of the cycle being released (None: no generator)
        # The tool's command the last step followed: one the tool changed since (the pump
        # stopped at a timeout) is a step still to take, however still the world was.
        self._tool_driven = None
        self.completed_id = 0  # the last completed cycle's message_id

    # -- questions a clock asks (and PacerQuestions') ------------------------------------------
    @property
    def busy(self) -> bool:
        """Something is under way that ends by itself: a motion, a recovery, a lost client's
        motion stopping, a tool's action."""
        return self.core.busy or self.tool_busy

    @property
    def tool_busy(self) -> bool:
        """A tool's action runs (a client may watch it and stop it)."""
        tool = self.tool
        return tool is not None and not tool.idle

    @property
    def at_rest(self) -> bool:
        """The next cycle would change nothing but message_id: no motion or recovery under way,
        the Hand idle, the robot's estimates steady, and the physics at rest (a step that can
        change nothing hands back the last measurement itself, physics "Rest")."""
        tool = self.tool
        return self._unchanged and self.core.settled and (
            tool is None or (tool.idle and tool.command == self._tool_driven))

    # -- the cycle -------------------------------------------------------------------------------
    def receive(self, command) -> bool:
        """A decoded RobotCommand; True if it answered the open cycle in time."""
        return self.core.receive_command(command)

    def release(self) -> Released:
        """This arm alone in its world (tests): drive, step, publish."""
        self.physics.step(*self._drive_command())
        return self.publish()

    def drive(self) -> None:
        self.physics.command(*self._drive_command())

    def _drive_command(self) -> tuple:
        core = self.core
        joint_command = core.release_cycle()
        self._q_d = core.desired_q
        self._tool_driven = None if self.tool is None else self.tool.command
        return joint_command, self._tool_driven

    def publish(self) -> Released:
        core, physics, q_d = self.core, self.physics, self._q_d
        measured = physics.measure()
        self._unchanged = measured is self._measured
        self._measured = measured
        kinematics = None if q_d is None else physics.flange_pose_and_jacobian(q_d)
        try:
            state = core.publish(measured, kinematics)
        except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
            self._failed()
            self._failing += 1
            if self._failing >= GIVE_UP_AFTER:  # ... but a world no cycle of which can be
                raise  # published is not served: the cycle thread fails, and the server
            state = None  # with it (503, a non-zero exit)
        else:
            self._failing = 0
        return Released(core.message_id, state, measured)

    def skip(self, cycles: int) -> None:
        """(Only between completed cycles: the ids skipped count as completed.)"""
        self.core.skip(cycles)
        if self.tool is not None:
            self.tool.skip(cycles)
        self.completed_id = self.core.message_id

    def repeat(self) -> Released:
        """A cycle that leaves the world as it is: the last state again under the next
        message_id, nothing stepped (complete it as any other). At rest it is the cycle that
        stepping would give, bit for bit."""
        core = self.core
        state = core.republish()
        return Released(core.message_id, state, self._measured)

    def complete(self, released: Released) -> Replies:
        """After the state has left: the tool, the rest of the step, the log-only checks. A
        cycle whose state could not be packed leaves its replies for the next one's state."""
        core, tool = self.core, self.tool
        robot_replies, tools = [], ()
        if released.state is not None:
            robot_replies = core.take_replies()
            if tool is not None:
                try:
                    tool.advance(released.message_id, released.measured.tool)
                    tool_replies, tool_state = tool.take_replies(), None
                    if tool.state_due(released.message_id) and self.tool_state_wanted():
                        tool_state = tool.pack_state(released.message_id)
                    if tool_replies or tool_state is not None:
                        tools = ((tool_replies, tool_state),)
                except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
                    self._failed()
        self.physics.finish_step()
        core.run_deferred_checks()
        self.completed_id = released.message_id
        if robot_replies or tools:
            return Replies(robot_replies, tools)
        return NO_REPLIES

    def _failed(self) -> None:
        self._failures += 1
        if worth_logging(self._failures):
            log.exception("cycle %d failed (%d so far)", self.core.message_id, self._failures)
