"""The publish loop: release a cycle, step physics once, publish the state, pace the next.

Callback-driven rather than a coroutine per cycle, because it runs 1000 times a second and a
callback chain is the cheapest thing asyncio does. Exactly one physics step per published
cycle; only the release instant depends on the wall clock (see pacing.py).
"""

from __future__ import annotations

import asyncio
import logging
import time
from typing import Callable

from franka_sim.physics.worker import PhysicsWorker
from franka_sim.robot.core import RobotCore
from franka_sim.server.pacing import Pacer
from franka_sim.server.timer import DeadlineTimer

log = logging.getLogger(__name__)


def _step(backend, joint_command, q_desired, fingers=None):
    """One physics step (with the Hand's finger command, if any), plus the desired-side
    kinematics when a generator sets q_d."""
    if fingers is None:  # no Hand command (or no Hand): the backend's step(cmd) as before
        measured = backend.step(joint_command)
    else:
        measured = backend.step(joint_command, fingers)
    if q_desired is None:
        return measured, None
    return measured, backend.flange_pose_and_jacobian(q_desired)


class CycleDriver:
    def __init__(
        self,
        core: RobotCore,
        worker: PhysicsWorker,
        publish: Callable[[bytes], None],
        *,
        lockstep: bool = False,
        after_cycle: Callable[[], None] | None = None,
        finger_command: Callable[[], object] | None = None,
    ) -> None:
        self.core = core
        self.worker = worker
        self.publish = publish
        self.lockstep = lockstep
        self.after_cycle = after_cycle
        self.finger_command = finger_command  # the gripper's drive command for the next step
        self.pacer = Pacer()
        self._loop: asyncio.AbstractEventLoop | None = None
        self._timer: DeadlineTimer | None = None
        self._token = 0
        self._busy = False
        self._running = False
        self._failures = 0
        self._idle = asyncio.Event()

    def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._timer = DeadlineTimer(self._loop, self._on_deadline)
        self._timer.start()
        self._running = True
        self._release()

    async def stop(self) -> None:
        self._running = False
        if self._timer is not None:
            self._timer.stop()
        if self._busy:
            await self._idle.wait()

    def release_early(self) -> None:
        """The command answering the open cycle arrived: in lockstep, go on at once."""
        if not (self._running and self.lockstep and self.core.motion_running):
            return  # realtime: the next cycle waits for its deadline
        if not self._busy:
            self._release()

    def _on_deadline(self, token: int) -> None:
        if token == self._token and self._running and not self._busy:
            self._release()

    def _release(self) -> None:
        self._busy = True
        self._idle.clear()
        self._token += 1  # invalidates any armed deadline for this cycle
        joint_command = self.core.joint_command()
        q_desired = self.core.desired_q
        fingers = None if self.finger_command is None else self.finger_command()
        self.worker.submit(_step, (joint_command, q_desired, fingers), self._on_stepped, self._loop)

    def _on_stepped(self, result) -> None:
        if isinstance(result, BaseException):
            log.error("physics step failed; publishing stopped: %s", result)
            self._running = False
        else:
            try:
                self.publish(self.core.publish(*result))
            except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
                self._failures += 1
                if self._failures in (1, 10, 100) or self._failures % 1000 == 0:
                    log.exception("cycle %d failed to publish (%d so far)",
                                  self.core.message_id, self._failures)
            if self.after_cycle is not None:
                self.after_cycle()
        released_at = time.monotonic()
        self._busy = False
        self._idle.set()
        if not self._running:
            return
        lockstep = self.lockstep and self.core.motion_running
        deadline = self.pacer.next_deadline(released_at, lockstep=lockstep)
        self._timer.arm(deadline, self._token)
