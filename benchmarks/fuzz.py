"""The long fuzz run: millions of hostile inputs against every decoder and both TCP sessions.

The generators and invariants are the property tests' (franka_sim.testing.fuzz_inputs and
fuzz_targets), driven here by a seeded random.Random instead of hypothesis, so a run is
reproducible from its seed and each crash prints the seed that replays it alone. Inputs go round
robin to: the robot's and the Hand's frame readers (a conversation's stream), the UDP decoders
(a RobotCommand datagram or random bytes), the robot's session with limits enforced and with
limits only logged, and the Hand's session. The session targets live on from one input to the
next (the robot's state carries over, as on a server that outlives its clients) and are rebuilt
every --renew inputs and after a crash.

Prints inputs per second as it goes and ends with the line `N inputs, K crashes`.
Physics instability under log-only limits (an absurd command applied as sent) is counted apart,
not as a crash (see docs/robustness.md).

python benchmarks/fuzz.py --inputs 1000000 [--seed 0] [--renew 2000]
"""

from __future__ import annotations

import argparse
import logging
import time
import traceback
import warnings

from franka_sim.robot.session import GRIPPER, ROBOT
from franka_sim.testing.fuzz_inputs import (
    GRIPPER_WIRE,
    ROBOT_WIRE,
    RandomChooser,
    conversation,
    robot_command,
)
from franka_sim.testing.fuzz_targets import (
    GripperTarget,
    RobotTarget,
    check_datagram,
    check_frame_reader,
    fuzz_session,
)

TARGETS = ("robot frames", "gripper frames", "datagrams", "robot session (limits enforced)",
           "robot session (limits logged)", "gripper session")


def _targets() -> dict:
    return {3: RobotTarget(True), 4: RobotTarget(False), 5: GripperTarget()}


def _unstable(target) -> bool:
    return any(w.number for w in target.cycle.physics.data.warning)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--inputs", type=int, default=100_000)
    parser.add_argument("--seed", type=int, default=0, help="input i is generated from seed + i")
    parser.add_argument("--renew", type=int, default=2000,
                        help="rebuild the session targets every this many inputs")
    args = parser.parse_args()
    logging.disable(logging.CRITICAL)  # rejections are logged by design: millions of lines
    warnings.simplefilter("ignore")  # numpy's overflow warnings on absurd (rejected) values
    targets, crashes, unstable = _targets(), 0, 0
    per_target = [0] * len(TARGETS)
    start = last = time.perf_counter()
    for i in range(args.inputs):
        seed, kind = args.seed + i, i % len(TARGETS)
        c = RandomChooser(seed)
        try:
            if kind == 0:
                check_frame_reader(ROBOT, conversation(c, ROBOT_WIRE))
            elif kind == 1:
                check_frame_reader(GRIPPER, conversation(c, GRIPPER_WIRE))
            elif kind == 2:
                check_datagram(robot_command(c) if c.integer(0, 3) else c.raw(1400))
            else:
                fuzz_session(c, targets[kind])
                if kind == 4 and _unstable(targets[kind]):
                    unstable += 1
                    targets[kind] = RobotTarget(False)
        except Exception:  # noqa: BLE001 - a crash: count it, show it, go on
            crashes += 1
            per_target[kind] += 1
            if crashes <= 10:
                print(f"crash in {TARGETS[kind]} (input seed {seed}); replay it on fresh "
                      f"targets with --seed {seed - kind} --inputs {kind + 1}")
                traceback.print_exc()
            targets = _targets()
        if (i + 1) % args.renew == 0:
            targets = _targets()
        now = time.perf_counter()
        if now - last >= 10:
            print(f"{i + 1} inputs, {(i + 1) / (now - start):.0f} inputs/s, {crashes} crashes",
                  flush=True)
            last = now
    elapsed = time.perf_counter() - start
    print(f"{args.inputs / elapsed:.0f} inputs/s over {elapsed:.0f} s")
    for name, count in zip(TARGETS, per_target):
        print(f"  {name}: {count} crashes")
    print(f"  physics unstable under log-only limits: {unstable} sessions")
    print(f"{args.inputs} inputs, {crashes} crashes")


if __name__ == "__main__":
    main()
