"""The publish loop: release a cycle, step physics once, publish the state, pace the next.

Callback-driven rather than a coroutine per cycle, because it runs 1000 times a second and a
callback chain is the cheapest thing asyncio does. Exactly one physics step per published
cycle; only the release instant depends on the wall clock (see pacing.py). The physics worker
keeps the deadline (its wait for the next job is the precise sleep) and runs the job the loop
left in its slot, so a realtime cycle costs two hand-overs: worker (step) → loop (publish),
and the loop fills the slot for the next one. While the arm is idle the next cycle's command
is known at once, so the worker steps it ahead and sends the state the loop posts back on the
deadline (physics/worker.py, "Ahead of time"); during a motion the command comes from the
client, so the step waits for the deadline and the loop sends the state as soon as it is
packed.

The clock pauses while nobody is connected and the arm has settled (PAUSE_AFTER cycles after
the last client left): nothing can observe it, and an idle fleet of simulators then costs no
CPU. The next client resumes it at once; message_id carries on from where it stopped.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Callable

from franka_sim.physics.worker import PhysicsWorker
from franka_sim.robot.core import RobotCore
from franka_sim.server.pacing import Pacer

log = logging.getLogger(__name__)

PAUSE_AFTER = 2000  # cycles without a client before the clock pauses (the arm settles first)


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
        send_from_worker: Callable[[bytes], None] | None = None,
        lockstep: bool = False,
        after_cycle: Callable[[], None] | None = None,
        finger_command: Callable[[], object] | None = None,
        has_client: Callable[[], bool] = lambda: True,
    ) -> None:
        self.core = core
        self.worker = worker
        self.publish = publish
        self.send_from_worker = send_from_worker  # thread-safe send for states stepped ahead
        self._awaiting: list[tuple[int, Callable[[], None]]] = []  # (cycle, deliver) replies
        self.lockstep = lockstep
        self.after_cycle = after_cycle
        self.finger_command = finger_command  # the gripper's drive command for the next step
        self.has_client = has_client
        self.pacer = Pacer()  # used by the worker thread only (inside wake_at)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._token = 0
        self._unwatched = 0  # cycles since a client was last connected
        self.paused = False
        self._busy = False
        self._running = False
        self._failures = 0
        self._idle = asyncio.Event()

    def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._running = True
        self._release()

    async def stop(self) -> None:
        self._running = False
        self._token += 1  # a wake-up already on its way finds nothing to do
        self.worker.fill_slot(-1, None)  # and the worker has nothing left to run
        if self._busy:
            await self._idle.wait()

    def resume(self) -> None:
        """A client arrived: restart a paused clock at once."""
        self._unwatched = 0
        if self.paused and self._running and not self._busy:
            self.paused = False
            self._release()

    @property
    def _lockstep_now(self) -> bool:
        """Lockstep pacing applies: a motion streams commands (an async motion does not)."""
        motion = self.core.motion
        return (self.lockstep and motion is not None and motion.running
                and not motion.spec.use_async)

    def release_early(self) -> None:
        """The command answering the open cycle arrived (the core closed its window)."""
        if not self._running:
            return
        if self._lockstep_now:
            if not self._busy:
                self._release()  # lockstep: go on at once
        else:
            self.refresh()  # realtime: the next cycle is decided; the worker runs it on time

    def after_next_state(self, deliver: Callable[[], None]) -> bool:
        """Call `deliver` (a request's replies) once the first state published after now
        has been sent; False while no state is coming (stopped, paused): deliver now.

        A client that reads the state after a reply (libfranka takes the newest one queued)
        then always sees what its request did, wherever the reply fell between two states.
        """
        if not self._running or self.paused:
            return False
        self._awaiting.append((self.core.message_id + 1, deliver))
        return True

    def _state_sent(self, cycle: int) -> None:
        """The state of `cycle` has left: deliver the replies that waited for it."""
        awaiting = self._awaiting
        while awaiting and awaiting[0][0] <= cycle:
            awaiting.pop(0)[1]()

    def _sender(self, cycle: int, *, then_after_cycle: bool) -> Callable[[bytes], None]:
        """The worker's send for `cycle`; it tells the loop when that state has left if
        replies wait for it (or `then_after_cycle`: run after_cycle only then)."""
        send, loop = self.send_from_worker, self._loop

        def send_state(data: bytes) -> None:  # runs in the worker thread
            send(data)
            if then_after_cycle or self._awaiting:
                try:
                    loop.call_soon_threadsafe(self._sent, cycle, then_after_cycle)
                except RuntimeError:  # loop closed during shutdown
                    pass
        return send_state

    def _sent(self, cycle: int, then_after_cycle: bool) -> None:
        self._state_sent(cycle)
        if then_after_cycle and self._running and self.after_cycle is not None:
            self.after_cycle()

    def refresh(self) -> None:
        """Give the worker the next cycle's job if the core can decide it now.

        Called after each publish, each on-time answer and each TCP request (any of which may
        change what the next cycle does). With the slot filled, the deadline costs no trip
        through the loop; without it (a motion waiting for its answer), the worker asks.
        """
        if not self._running or self.paused or not self.core.decided:
            return
        if self._lockstep_now:
            return  # lockstep releases on the answer itself
        cycle = self.core.message_id + 1
        ahead = self.send_from_worker is not None and self.core.motion is None
        self.worker.fill_slot(cycle, self._job(cycle), ahead=ahead)

    def _on_deadline(self, token: int) -> None:
        if token == self._token and self._running and not self._busy:
            self._release()

    def _release(self) -> None:
        """Release the next cycle now, from the loop."""
        self._busy = True
        self._idle.clear()
        self._token += 1  # invalidates any wake-up armed for this cycle
        self.worker.submit_job(self._job(self.core.message_id + 1))

    def _job(self, cycle: int) -> tuple:
        """The release job of `cycle`: the core's joint command (closing its window if still
        open), the physics step, and when the worker should expect the cycle after it."""
        joint_command = self.core.joint_command()
        q_desired = self.core.desired_q
        fingers = None if self.finger_command is None else self.finger_command()
        self._unwatched = 0 if self.has_client() else self._unwatched + 1
        keep_going = self._unwatched < PAUSE_AFTER or self.core.motion is not None
        self.paused = not keep_going
        lockstep = self._lockstep_now
        pacer, token = self.pacer, self._token

        def wake_at(now: float) -> float | None:  # runs in the worker thread
            return pacer.next_deadline(now, lockstep=lockstep) if keep_going else None

        return PhysicsWorker.release_job(
            _step, (joint_command, q_desired, fingers),
            lambda result: self._on_stepped(result, cycle), self._loop,
            wake_at, lambda: self._on_deadline(token), cycle)

    def _on_stepped(self, result, cycle: int) -> None:
        if isinstance(result, BaseException):
            log.error("physics step failed; publishing stopped: %s", result)
            self._running = False
        else:
            ahead = self.send_from_worker is not None
            deferred = False
            try:
                data = self.core.publish(*result)
                # A reply the cycle produced (a Move's end, a recovery) must not overtake the
                # state that shows its effect: after_cycle (which sends it) follows that state.
                deferred = ahead and self.core.has_replies
                if not ahead or not self.worker.post(
                        cycle, data, self._sender(cycle, then_after_cycle=deferred)):
                    deferred = False
                    self.publish(data)
                    self._state_sent(cycle)
            except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
                if ahead:
                    self.worker.post(cycle, None, self.send_from_worker)  # the worker goes on
                self._failures += 1
                if self._failures in (1, 10, 100) or self._failures % 1000 == 0:
                    log.exception("cycle %d failed to publish (%d so far)",
                                  self.core.message_id, self._failures)
            if self.after_cycle is not None and not deferred:
                self.after_cycle()
        self._busy = False
        self._idle.set()
        if self.paused and self._running and self.has_client():  # a client came meanwhile
            self.resume()
        else:
            self.refresh()
