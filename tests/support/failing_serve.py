"""`python -m franka_sim.serving ARGUMENT` whose world cycle fails on purpose, half a second
into its run: how a test meets a simulator that stops simulating.

    python tests/support/failing_serve.py ARGUMENT   (franka_sim.serving.serving_argument)
"""

from __future__ import annotations

import sys

from franka_sim.robot.arm_cycle import ArmCycle
from franka_sim.serving import main

FAIL_AT = 500  # cycles: before the clock of a server without clients pauses (2000)

_publish = ArmCycle.publish


def _publish_then_fail(self):
    if self.core.message_id >= FAIL_AT:
        raise RuntimeError("injected failure")
    return _publish(self)


ArmCycle.publish = _publish_then_fail

if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
