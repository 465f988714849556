"""Not a benchmark: starts franka-sim 1.1.7 (the simulator franka-sim is compared with) on one
loopback address, so that it runs beside ours and beside other benchmarks.

Its own command (`run-franka-sim-server`) binds 0.0.0.0; this passes `host=$FRANKA_SIM_HOST` to
its server class, then runs its unchanged command line with the remaining arguments. Run it with
the interpreter of the virtual environment franka-sim 1.1.7 is installed in, isolated (`-I`:
both packages are called `franka_sim`). docs/benchmarks.md, "Beside franka-sim 1.1.7".
"""

import functools
import os
import sys

import franka_sim  # 1.1.7's
from franka_sim import run_server

franka_sim.FrankaSimServer = functools.partial(franka_sim.FrankaSimServer,
                                               host=os.environ.get("FRANKA_SIM_HOST", "0.0.0.0"))
sys.exit(run_server.main())
