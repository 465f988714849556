"""An active-control loop through pylibfranka, as a controller would run it.

Prints the robot-reported success rate, states/s seen by the client, the server's CPU % of one
core, and (lockstep) simulated seconds per wall second. Targets on an idle 2-core machine:
success ≥ 0.999 (realtime), lockstep ≥ 10× real time, server CPU ≤ 16 % while controlling.
The server's CPU is also split by thread (the physics thread runs the cycle; the rest is the
event loop reading commands and serving TCP), and the load the rest of the machine put on the
CPUs during the run is printed: trust a CPU figure only when that load was low.

python benchmarks/control_loop.py [--seconds 10] [--clock realtime|lockstep] [--mode torque|joint]
python benchmarks/control_loop.py --reference [--clock lockstep]   # the floor: protocol only
python benchmarks/control_loop.py --reference --physics [--clock lockstep]   # + the stripped cycle
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np
import pylibfranka

from _common import (Load, cpu_seconds, idle_behaviour, responder_command, thread_cpu_seconds,
                     verdict)
from franka_sim.server.cycle_thread import OS_THREAD_NAME
from franka_sim.testing import ServerProcess

PRIVATE_HOST = "127.0.0.201"
PHYSICS_THREAD = OS_THREAD_NAME.decode()  # the name the cycle thread has in /proc


def control(host: str, seconds: float, mode: str) -> dict:
    robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
    if mode == "torque":
        active = robot.start_torque_control()
    else:
        active = robot.start_joint_position_control(pylibfranka.ControllerMode.JointImpedance)
    state, _ = active.readOnce()
    q0 = np.array(state.q_d)
    rates, n, t = [], 0, 0.0
    wall0, sim0 = time.perf_counter(), state.time.to_sec()
    while True:
        state, period = active.readOnce()
        t += period.to_sec()
        n += 1
        rates.append(state.control_command_success_rate)
        finished = t >= seconds
        if mode == "torque":
            command = pylibfranka.Torques([0.0] * 7)
        else:
            q = q0.copy()
            q[6] += 0.1 * (1 - math.cos(2 * math.pi * t / seconds)) / 2
            command = pylibfranka.JointPositions(q.tolist())
        command.motion_finished = finished
        active.writeOnce(command)
        if finished:
            break
    wall = time.perf_counter() - wall0
    sim = state.time.to_sec() - sim0
    after_warmup = rates[200:] or rates
    return {"cycles": n, "wall": wall, "sim": sim, "mean_rate": float(np.mean(after_warmup)),
            "min_rate": float(np.min(after_warmup))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds of control")
    parser.add_argument("--clock", choices=["realtime", "lockstep"], default="realtime")
    parser.add_argument("--mode", choices=["torque", "joint"], default="torque")
    parser.add_argument("--host", default=PRIVATE_HOST)
    parser.add_argument("--reference", action="store_true",
                        help="measure reference_responder.py (the protocol alone) instead")
    parser.add_argument("--physics", action="store_true",
                        help="with --reference: the responder runs the stripped torque cycle")
    args = parser.parse_args()
    if args.physics and not args.reference:
        parser.error("--physics goes with --reference")
    if args.reference:
        server = ServerProcess(args.host, command=responder_command(args.host, args.clock,
                                                                     args.physics))
    else:
        server = ServerProcess(args.host, "--clock", args.clock)
    server.wait_ready()
    try:
        cpu0, threads0 = cpu_seconds(server.pid), thread_cpu_seconds(server.pid)
        load = Load(exclude={server.pid})
        result = control(args.host, args.seconds, args.mode)
        other_cpu, pressure = load.stop()
        cpu = (cpu_seconds(server.pid) - cpu0) / result["wall"] * 100
        threads = {name: (seconds - threads0.get(name, 0.0)) / result["wall"] * 100
                   for name, seconds in thread_cpu_seconds(server.pid).items()}
    finally:
        server.stop()
    speed = result["sim"] / result["wall"]
    what = "reference_responder.py" if args.reference else "franka-sim"
    what += " --physics" if args.physics else ""
    print(f"{what} control loop: {args.mode}, {args.clock} clock, {result['cycles']} cycles")
    if not args.reference:  # the responder reports no success rate
        print(f"  success rate (mean / min after 200 cycles)  {result['mean_rate']:.4f} / "
              f"{result['min_rate']:.4f}   target ≥ 0.999 (realtime)  "
              f"{verdict(result['mean_rate'] >= 0.999) if args.clock == 'realtime' else ''}")
    print(f"  states/s seen by the client                 {result['cycles'] / result['wall']:.1f}")
    print(f"  simulated s per wall s                      {speed:.2f}   "
          f"{'target ≥ 10 ' + verdict(speed >= 10) if args.clock == 'lockstep' else ''}")
    if args.clock == "realtime":
        print(f"  server CPU % of a core                      {cpu:.1f}   target ≤ 16  "
              f"{verdict(cpu <= 16)}")
    else:  # a faster clock does more cycles per wall second: the target is for real time
        print(f"  server CPU % of a core                      {cpu:.1f}   "
              f"({cpu / speed:.1f} per simulated second)")
    if PHYSICS_THREAD in threads:  # (the responder has one thread)
        physics = threads[PHYSICS_THREAD]
        print(f"    physics thread / rest                     {physics:.1f} / "
              f"{max(cpu - physics, 0.0):.1f}")
    print(f"  machine: {os.cpu_count()} CPUs; other processes used {other_cpu:.0f} % of a core "
          f"(this client's own process excluded), tasks waited for a CPU {pressure:.0f} % of "
          f"the time{idle_behaviour()}")


if __name__ == "__main__":
    main()
