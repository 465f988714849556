"""One arm's live plots and readouts in the web view's side panel, from the RobotState bytes
a snapshot holds (decoded on the web thread: exactly what the arm's client was sent).

Plots: q against q_d and tau_J against tau_J_d for the joint the dropdown picks, the external
wrench's force, and the command success rate, over the last WINDOW seconds. Readouts: the
robot mode, the active errors, the last reflex's reasons, q and the wrench as numbers (what a
test compares to the control API's /state).
"""

from __future__ import annotations

from collections import deque

import numpy as np

from franka_sim.protocol.codec import decode_state
from franka_sim.protocol.enums import RobotMode
from franka_sim.protocol.errors import ERROR_NAMES

WINDOW = 10.0  # s of history in the plots
PLOT_PERIOD = 0.2  # s between two plot updates (the readouts follow every frame)
DIGITS = 4  # decimals of the numeric readouts
_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")


def mode_name(value: int) -> str:
    try:
        return RobotMode(value).name[1:]
    except ValueError:
        return f"unknown ({value})"


def error_names(bits) -> str:
    names = [ERROR_NAMES[i] for i in np.flatnonzero(bits)]
    return ", ".join(names) or "none"


def numbers(values) -> str:
    return " ".join(f"{float(v):.{DIGITS}f}" for v in values)


def _series(*labels: str) -> tuple[dict, ...]:
    return ({"label": "t (s)"},
            *({"label": label, "stroke": _COLORS[i], "width": 1.5}
              for i, label in enumerate(labels)))


class ArmPanel:
    """`gui`: viser's GuiApi; `index`: the arm's robot index in a snapshot's states."""

    def __init__(self, gui, name: str, index: int, t0: float | None = None) -> None:
        """`t0`: the plots' time origin (None: the first snapshot's time)."""
        self.index = index
        self._rows: deque = deque()  # (t, q, q_d, tau_J, tau_J_d, F_ext, success rate)
        self._t0 = t0
        self._last_plot = 0.0
        self._last_state: bytes | None = None
        with gui.add_folder(f"arm {name}"):
            self.mode = gui.add_text("robot mode", "no state sent yet (no client)",
                                     disabled=True)
            self.errors = gui.add_text("errors", "-", disabled=True)
            self.reflex = gui.add_text("last reflex", "none", disabled=True)
            self.success = gui.add_text("success rate", "-", disabled=True)
            self.q = gui.add_text("q (rad)", "-", disabled=True)
            self.wrench = gui.add_text("O_F_ext_hat_K", "-", disabled=True)
            self.joint = gui.add_dropdown("joint", [str(j) for j in range(1, 8)],
                                          initial_value="1")
            empty = (np.zeros(0),) * 3
            self.q_plot = gui.add_uplot(empty, _series("q", "q_d"), title="q vs q_d (rad)",
                                        aspect=2.0)
            self.tau_plot = gui.add_uplot(empty, _series("tau_J", "tau_J_d"),
                                          title="tau_J vs tau_J_d (Nm)", aspect=2.0)
            self.force_plot = gui.add_uplot((np.zeros(0),) * 4, _series("Fx", "Fy", "Fz"),
                                            title="external force at K (N)", aspect=2.0)
            self.rate_plot = gui.add_uplot((np.zeros(0),) * 2, _series("success rate"),
                                           title="command success rate", aspect=2.0)

    def show(self, snapshot) -> None:
        """Readouts from the snapshot's state of this arm; the plots every PLOT_PERIOD."""
        states = snapshot.states
        data = states[self.index] if self.index < len(states) else None
        if data is None or data is self._last_state:
            return
        self._last_state = data
        s = decode_state(data)
        if self._t0 is None:
            self._t0 = snapshot.time
        t = snapshot.time - self._t0
        if self._rows and t < self._rows[-1][0]:  # a timeline scrubbed back: start again
            self._rows.clear()
            self._last_plot = -PLOT_PERIOD
        self.mode.value = mode_name(int(s["robot_mode"]))
        self.errors.value = error_names(s["errors"])
        if np.any(s["reflex_reason"]):
            self.reflex.value = error_names(s["reflex_reason"])
        self.success.value = f"{float(s['control_command_success_rate']):.3f}"
        self.q.value = numbers(s["q"])
        self.wrench.value = numbers(s["O_F_ext_hat_K"])
        rows = self._rows
        rows.append((t, s["q"].copy(), s["q_d"].copy(), s["tau_J"].copy(), s["tau_J_d"].copy(),
                     s["O_F_ext_hat_K"][:3].copy(), float(s["control_command_success_rate"])))
        while rows and rows[0][0] < t - WINDOW:
            rows.popleft()
        if abs(snapshot.time - self._last_plot) >= PLOT_PERIOD:
            self._last_plot = snapshot.time
            self._plot()

    def _plot(self) -> None:
        rows, j = self._rows, int(self.joint.value) - 1
        t = np.array([r[0] for r in rows])
        self.q_plot.data = (t, np.array([r[1][j] for r in rows]),
                            np.array([r[2][j] for r in rows]))
        self.tau_plot.data = (t, np.array([r[3][j] for r in rows]),
                              np.array([r[4][j] for r in rows]))
        forces = np.array([r[5] for r in rows]).reshape(-1, 3)
        self.force_plot.data = (t, forces[:, 0], forces[:, 1], forces[:, 2])
        self.rate_plot.data = (t, np.array([r[6] for r in rows]))
