"""The robot's cycle, run as the physics worker's tick: commands in, one step, the state out.

A tick is a whole cycle in the physics thread: the commands that arrived since the last one go
to the core (closing the open cycle's window), the core decides the drives' task, MuJoCo steps
once (the part of the step the state does not need waits until it has left: `finish_step`),
the core packs the RobotState and the thread sends it. One wake-up per cycle: on a 2-core
VM every extra hand-over between threads cost more CPU than the cycle's own work. Only the tick
reads the UDP socket (`poll_commands`: the endpoint decodes and checks each datagram and hands
the commands to `receive`): at each deadline, and in lockstep also when an answer arrives (the
worker watches the socket while a lockstep cycle waits, see PhysicsWorker.watch). The loop owns
the endpoints and serves TCP. The core is shared between the two threads, so it is only touched
with `lock` held: the tick holds it for the whole cycle, the TCP endpoints for each request.

While the arm is idle the next cycle's command is known at once (the hold), so the tick steps
and packs it straight after sending the current state, and the next tick only sends it: idle
states leave on their deadline to within this thread's wake-up. During a motion the command
comes from the client, so the cycle runs when its deadline comes (realtime) or when the answer
arrives (lockstep, see pacing.py; the tick reads the socket for a moment before it goes to
sleep watching it, see `_await_answer`), and the state leaves as soon as it is packed.

In lockstep the cycle after a motion's last waits for the client's next request (or a lockstep
window), so how many idle cycles separate two motions does not depend on how fast the client
was: back-to-back motions reproduce to the bit.

A request's replies wait for the first state published after it (`after_next_state`), and a
reply the cycle itself produced (a Move's end, a recovery) goes out after the state that shows
it: libfranka reads the newest queued state after a reply, which must show what the reply says.

The clock pauses while nobody is connected and the arm has settled (PAUSE_AFTER cycles after
the last client left): nothing can observe it, and an idle fleet of simulators then costs no
CPU. The next client resumes it at once; message_id carries on from where it stopped.
"""

from __future__ import annotations

import asyncio
import collections
import logging
import threading
import time
from typing import Callable

from franka_sim.physics.backend import Measured
from franka_sim.physics.worker import PhysicsWorker
from franka_sim.robot.core import RobotCore
from franka_sim.server.pacing import LOCKSTEP_WINDOW, Pacer

log = logging.getLogger(__name__)

PAUSE_AFTER = 2000  # cycles without a client before the clock pauses (the arm settles first)
LOCKSTEP_SPIN = 300e-6  # s a lockstep tick keeps reading the socket for the answer before sleeping

# on_cycle(cycle, measured), in the physics thread with the lock held, right after the state
# of `cycle` was sent: what else the cycle does (the Hand), and what the loop must send now
# (the replies it produced), as a function to call there, or None.
OnCycle = Callable[[int, Measured], "Callable[[], None] | None"]


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
        lock: threading.Lock,
        send_state: Callable[[bytes], None],
        *,
        lockstep: bool = False,
        on_cycle: OnCycle | None = None,
        finger_command: Callable[[], object] | None = None,
        has_client: Callable[[], bool] = lambda: True,
        poll_commands: Callable[..., None] = lambda *limit: None,
        command_socket: Callable[[], object] = lambda: None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.core = core
        self.worker = worker
        self.lock = lock  # guards the core (and what on_cycle touches)
        self.send_state = send_state  # safe to call from the physics thread
        self.lockstep = lockstep
        self.on_cycle = on_cycle
        self.finger_command = finger_command  # the gripper's drive command for the next step
        self.has_client = has_client
        self.poll_commands = poll_commands  # poll_commands([limit]): datagrams into receive()
        self.command_socket = command_socket  # the socket poll_commands reads (or None)
        self.clock = clock  # the worker's clock (monotonic seconds): deadlines are on it
        self.pacer = Pacer()
        self._inbox: collections.deque = collections.deque()  # poll → tick: decoded commands
        self._awaiting: list[tuple[int, Callable[[], None]]] = []  # loop only: (cycle, deliver)
        self._loop: asyncio.AbstractEventLoop | None = None
        self._running = False
        # Physics thread only:
        self._prepared: tuple | None = None  # (cycle, data, measured) stepped ahead (idle)
        self._deadline: float | None = None
        self._unwatched = 0  # cycles since a client was last connected
        # Lockstep, after a motion: the next cycle waits for the client's next request (see
        # _tick_locked). `_requests` counts requests (loop, lock held), `_holding` is the
        # count the hold began at.
        self._requests = 0
        self._holding: int | None = None
        self.paused = False
        self._failures = 0

    # -- the loop's side -------------------------------------------------------------------------
    async def start(self) -> None:
        self._loop = asyncio.get_running_loop()
        self._running = True
        await self.worker.run_clock(self._tick)

    async def stop(self) -> None:
        self._running = False
        await self.worker.run_clock(None)  # no tick runs after this

    def receive(self, command) -> None:
        """A decoded RobotCommand from the client (physics thread, from poll_commands): the
        tick hands it to the core."""
        self._inbox.append(command)

    def resume(self) -> None:
        """A client arrived: a paused clock starts again at once (a wake-up that finds the
        clock running releases nothing)."""
        self.worker.wake()

    def after_next_state(self, deliver: Callable[[], None]) -> bool:
        """Call `deliver` (a request's replies) once the first state published after now has
        been sent; False while no state is coming (stopped, paused): deliver now. Lock held."""
        if not self._running or self.paused:
            return False
        self._awaiting.append((self.core.message_id + 1, deliver))
        self._requests += 1
        if self._holding is not None:
            self.worker.wake()  # the held cycle goes now, after this request
        return True

    def _sent(self, cycle: int, deliver: Callable[[], None] | None) -> None:
        """The state of `cycle` has left: the replies that waited for it, then its own."""
        awaiting = self._awaiting
        while awaiting and awaiting[0][0] <= cycle:
            awaiting.pop(0)[1]()
        if deliver is not None and self._running:
            deliver()

    # -- the physics thread's side ---------------------------------------------------------------
    @property
    def _lockstep_now(self) -> bool:
        """Lockstep pacing applies: a motion streams commands (an async motion does not)."""
        motion = self.core.motion
        return (self.lockstep and motion is not None and motion.running
                and not motion.spec.use_async)

    def _tick(self, backend, due: bool) -> float | None:
        try:
            with self.lock:
                deadline = self._tick_locked(backend, due)
            while self._lockstep_now:
                if not self._await_answer():
                    self.worker.watch(self.command_socket())  # wait asleep for the answer
                    break
                with self.lock:
                    deadline = self._tick_locked(backend, False)
            return deadline
        except BaseException:
            self._running = False  # the worker logs it and stops the clock
            raise

    def _await_answer(self) -> bool:
        """Lockstep: read the socket for the answer for up to LOCKSTEP_SPIN, without sleeping.

        A client answers within ~50 µs here; a thread that slept meanwhile is woken by the
        kernel and then runs its cycle on cold caches, which made a lockstep cycle ~30 % slower.
        This costs CPU only while a lockstep motion runs, and at most LOCKSTEP_SPIN per cycle (a
        slower answer is waited for asleep, the worker watching the socket).
        """
        clock = self.clock
        spin_until = clock() + LOCKSTEP_SPIN
        poll, inbox = self.poll_commands, self._inbox
        while True:
            poll(1)  # the answer, and not a further read that finds the socket empty
            if inbox:
                return True
            if clock() > spin_until:
                return False

    def _tick_locked(self, backend, due: bool) -> float | None:
        lockstep = self._lockstep_now  # (before the answer: it may end the motion)
        moving = self.core.motion is not None
        answered = self._take_commands()
        # Only this thread reads the socket: at every deadline, idle ones too (a stray datagram
        # is counted and logged within a cycle); in lockstep also in _await_answer (_tick).
        ready = self._prepared is not None  # an idle cycle stepped ahead: it goes first
        if due and not ready:
            answered = self._read_socket() or answered  # an answer in time counts
        requested = self._holding is not None and self._requests != self._holding
        if not due and not self.paused and not (answered and lockstep) and not requested:
            return self._deadline  # woken, but nothing to release
        self.paused = False
        self._holding = None
        prepared, self._prepared = self._prepared, None
        # A motion's cycle (or its last): the client may start its next motion at once, so the
        # cycle after it is decided when it goes, not ahead of it.
        moved = prepared is None and moving
        if prepared is None:
            prepared = self._cycle(backend)
        self._send(prepared)
        sent_at = self.clock()  # what the next deadline counts from (pacing.py)
        backend.finish_step()  # the part of the step no reading needed, now the state is out
        self.core.run_deferred_checks()  # limit checks that only log (not enforced)
        if due and ready:  # no command can answer an idle state: what came
            self._read_socket()  # (strays, junk) is read once the state has left
        self._unwatched = 0 if self.has_client() else self._unwatched + 1
        if self._unwatched >= PAUSE_AFTER and self.core.motion is None:
            self.paused = True
            self._deadline = None
            return None
        if self.core.motion is None and not moved:  # idle: the next command is the hold
            self._prepared = self._cycle(backend)
        if moved and self.lockstep and self.core.motion is None:
            # A lockstep motion just ended. Its client's next step (the next Move, a read)
            # decides when the next cycle goes, not how fast it answered within a 1 ms
            # deadline: so a program of back-to-back motions reproduces to the bit. The cycle
            # goes on the client's next request, or at the end of a lockstep window.
            self._holding = self._requests
            self._deadline = sent_at + LOCKSTEP_WINDOW
            return self._deadline
        self._deadline = self.pacer.next_deadline(sent_at, lockstep=self._lockstep_now)
        return self._deadline

    def _read_socket(self) -> bool:
        """The datagrams on the socket now, to the core; True if one answered in time."""
        self.poll_commands()
        return self._take_commands()

    def _take_commands(self) -> bool:
        """Hand the queued commands to the core; True if one answered the open cycle in time."""
        answered = False
        inbox, core = self._inbox, self.core
        while inbox:
            answered = core.receive_command(inbox.popleft()) or answered
        return answered

    def _cycle(self, backend) -> tuple:
        """Release the next cycle: decide, step, publish. (cycle, state bytes, measured)."""
        core = self.core
        joint_command = core.joint_command()
        q_desired = core.desired_q
        fingers = None if self.finger_command is None else self.finger_command()
        measured, kinematics = _step(backend, joint_command, q_desired, fingers)
        data = None
        try:
            data = core.publish(measured, kinematics)
        except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
            self._failed()
        return core.message_id, data, measured

    def _failed(self) -> None:
        self._failures += 1
        if self._failures in (1, 10, 100) or self._failures % 1000 == 0:
            log.exception("cycle %d failed (%d so far)", self.core.message_id, self._failures)

    def _send(self, prepared: tuple) -> None:
        """Send a cycle's state, then the rest of the cycle (on_cycle: the Hand, the replies
        to hand to the loop): a lockstep client is not kept waiting for them."""
        cycle, data, measured = prepared
        if data is None:
            return
        self.send_state(data)
        deliver = None
        if self.on_cycle is not None:
            try:
                deliver = self.on_cycle(cycle, measured)
            except Exception:  # noqa: BLE001 - one bad cycle must not end the stream
                self._failed()
        if deliver is not None or self._awaiting:
            try:
                self._loop.call_soon_threadsafe(self._sent, cycle, deliver)
            except RuntimeError:  # loop closed during shutdown
                pass
