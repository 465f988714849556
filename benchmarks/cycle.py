"""µs of one motion cycle's own work, in a tight loop, without sockets or threads.

What the cycle thread does per cycle, through the server's own world cycle (a `WorldCycle`
of one arm's `ArmCycle`, as `franka-sim serve` runs it), section by section: `release` (the core closes the command window and decides the drives' task, MuJoCo
steps, the desired-side kinematics, the core packs the state), `complete` (once the state is
out: the rest of mj_step1 and the next g(q), and the limit checks that only log, none of which
a client waits for), and the client's answer is decoded (`decode`) and taken by the cycle
(`receive`: on time? which command applies; the limit checks too when they are enforced, not
measured here). `critical` is what a lockstep client waits for: all but `complete`. A server runs the same code,
but after a sleep between cycles, where this VM runs it 2–3× slower (docs/benchmarks.md): read
these as the floor, not as the server's CPU.
`--floor` times, in place of franka-sim's cycle, the answer's decode and the stripped torque
cycle of benchmarks/_floor.py (only the MuJoCo calls a torque cycle cannot skip, and a state
with five fields): what franka-sim's features cost is the difference.
`--sleep US` puts that sleep back (a timed `select`, as the physics thread waits, with its timer
slack) and also prints the thread's CPU time per cycle, the wait's included (and the answer's
encoding, a few µs of the client's part): what the same work costs when the thread sleeps
between cycles, still without sockets or a client.

    python benchmarks/cycle.py [--cycles 5000] [--mode torque|joint|cartesian] [--floor]
                               [--sleep 800]
"""

from __future__ import annotations

import argparse
import math
import select
import time

import numpy as np

from _common import idle_behaviour
from _floor import StrippedCycle
from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import default_scene_path
from franka_sim.server.cycle_thread import _tune_this_thread
from franka_sim.protocol import robot_messages as msg
from franka_sim.protocol.codec import StateBuffer, decode_command, decode_state, encode_command
from franka_sim.protocol.enums import Command
from franka_sim.protocol.framing import Frame, decode_request
from franka_sim.robot.arm_core import ArmCore
from franka_sim.robot.arm_cycle import ArmCycle
from franka_sim.robot.world_cycle import WorldCycle

SECTIONS = ("release", "complete", "decode", "receive")
FLOOR_SECTIONS = ("decode", "step", "publish", "finish")
# (controller, generator) of the Move request
MOVES = {"torque": (2, 4), "joint": (0, 0), "cartesian": (0, 2)}


def _move(core: ArmCore, controller: int, generator: int) -> None:
    deviation = dict(translation=10.0, rotation=3.12, elbow=2 * math.pi)
    data = msg.build_request(
        Command.Move, 1, controller_mode=controller, motion_generator_mode=generator,
        maximum_path_deviation=deviation, maximum_goal_pose_deviation=deviation,
        use_async_motion_generator=False, maximum_velocity=[0.0] * 7)
    core.request_move(1, decode_request(Frame(int(Command.Move), 1, data)))


def _time_cycles(sections: tuple[str, ...], one_cycle, cycles: int, warmup: int,
                 sleep: float) -> dict[str, float]:
    """µs per cycle by section (`one_cycle(k)` returns each section's seconds); with `sleep`
    (s) before each cycle, also `cpu`: the thread's CPU time per cycle, the sleep included."""
    totals = dict.fromkeys(sections, 0.0)
    cpu0 = 0.0
    if sleep:
        _tune_this_thread()
    for k in range(warmup + cycles):
        if k == warmup:
            totals = dict.fromkeys(sections, 0.0)
            cpu0 = time.thread_time()
        if sleep:
            select.select((), (), (), sleep)
        for name, dt in zip(sections, one_cycle(k)):
            totals[name] += dt
    us = {name: total / cycles * 1e6 for name, total in totals.items()}
    if sleep:
        us["cpu"] = (time.thread_time() - cpu0) / cycles * 1e6
    return us


def run(mode: str, cycles: int, warmup: int = 500, sleep: float = 0.0) -> dict[str, float]:
    """franka-sim's motion cycle, by section (see _time_cycles)."""
    desc = load_arm_description(default_urdf_text())
    q0 = np.array(READY_POSE)
    backend = MujocoBackend(desc, q0, scene_xml=default_scene_path(), tool=FINGERS)
    core = ArmCore(desc, q0)
    cycle = WorldCycle([ArmCycle(core, backend)], backend.world.step)
    cycle.complete(cycle.release())
    _move(core, *MOVES[mode])
    released = cycle.release()
    cycle.complete(released)
    start = decode_state(released.states[0])
    q_start, pose_start = np.array(start["q_d"]), np.array(start["O_T_EE_c"], dtype=float)
    clock = time.perf_counter

    def one_cycle(k: int) -> tuple[float, ...]:
        t0 = clock()
        released = cycle.release()
        t1 = clock()
        cycle.complete(released)
        t2 = clock()
        if mode == "torque":
            answer = encode_command(message_id=released.message_id, tau_J_d=[0.0] * 7)
        elif mode == "cartesian":  # a slow sway of the flange along x, 5 mm
            pose = pose_start.copy()
            pose[12] += 0.005 * (1 - math.cos(k * 1e-3))
            answer = encode_command(message_id=released.message_id, O_T_EE_c=pose)
        else:  # a slow swing of joint 7, well inside every limit
            q_c = q_start.copy()
            q_c[6] += 0.005 * (1 - math.cos(k * 1e-3))
            answer = encode_command(message_id=released.message_id, q_c=q_c)
        t3 = clock()
        command = decode_command(answer)
        t4 = clock()
        cycle.receive(0, command)
        t5 = clock()
        return t1 - t0, t2 - t1, t4 - t3, t5 - t4

    return _time_cycles(SECTIONS, one_cycle, cycles, warmup, sleep)


def run_floor(cycles: int, warmup: int = 500, sleep: float = 0.0) -> dict[str, float]:
    """The stripped torque cycle (`--floor`, benchmarks/_floor.py), by section."""
    floor, state = StrippedCycle(), StateBuffer()
    answer = encode_command(message_id=1, tau_J_d=[0.0] * 7)
    clock = time.perf_counter

    def one_cycle(k: int) -> tuple[float, ...]:
        t0 = clock()
        tau_J_d = decode_command(answer)["tau_J_d"]
        t1 = clock()
        floor.step(tau_J_d)
        t2 = clock()
        floor.write(state, k)
        t3 = clock()
        floor.finish()
        t4 = clock()
        return t1 - t0, t2 - t1, t3 - t2, t4 - t3

    return _time_cycles(FLOOR_SECTIONS, one_cycle, cycles, warmup, sleep)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=5000)
    parser.add_argument("--mode", choices=sorted(MOVES), default="torque")
    parser.add_argument("--floor", action="store_true",
                        help="time the stripped torque cycle instead (see the docstring)")
    parser.add_argument("--sleep", type=float, default=0.0, metavar="US",
                        help="µs to sleep before each cycle (0: a tight loop)")
    args = parser.parse_args()
    loop = f"a {args.sleep:g} µs sleep before each" if args.sleep else "a tight loop"
    if args.floor:
        us, sections = run_floor(args.cycles, sleep=args.sleep * 1e-6), FLOOR_SECTIONS
        print(f"the floor: a stripped torque cycle, {args.cycles} cycles, {loop} (µs per cycle)")
    else:
        us, sections = run(args.mode, args.cycles, sleep=args.sleep * 1e-6), SECTIONS
        print(f"franka-sim cycle work, {args.mode} motion, {args.cycles} cycles, {loop} "
              "(µs per cycle)")
    for name in sections:
        print(f"  {name:8s} {us[name]:7.1f}")
    total = sum(us[name] for name in sections)
    print(f"  {'total':8s} {total:7.1f}")
    print(f"  {'critical':8s} {total - us['finish' if args.floor else 'complete']:7.1f}")
    if args.sleep:
        print(f"  {'cpu':8s} {us['cpu']:7.1f}   the thread's CPU time, the sleep's included "
              f"({us['cpu'] / 10:.1f} % of a core at 1 kHz){idle_behaviour()}")


if __name__ == "__main__":
    main()
