"""One arm's live plots and readouts in the web view's side panel, from the RobotState bytes
a snapshot holds (decoded on the web thread: exactly what the arm's client was sent).

Plots: q against q_d and tau_J against tau_J_d for the joint the dropdown picks, the external
wrench's force, and the command success rate, over the last WINDOW seconds. Readouts: the
robot mode, the active errors, the last reflex's reasons, q and the wrench as numbers (what a
test compares to the control API's /state), and the last few changes of mode, errors and
reflex, each with its time.
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
EVENTS = 6  # lines of the events readout (mode, errors and reflexes as they change)
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


def status_of(state) -> tuple[str, str, str]:
    """(robot mode, errors, reflex reasons) of a decoded state, by name."""
    return (mode_name(int(state["robot_mode"])), error_names(state["errors"]),
            error_names(state["reflex_reason"]))


def event_line(before: tuple | None, status: tuple, t: float) -> str:
    """The events readout's line for a change from `before` to `status` at `t` s."""
    mode, errors, reflex = status
    line = f"{t:.3f} s: {mode}"
    if before is None or errors != before[1]:
        line += f"; errors: {errors}"
    if reflex != "none" and (before is None or reflex != before[2]):
        line += f"; reflex: {reflex}"
    return line


def row_of(state, t: float) -> tuple:
    """A plots' row: (t, q, q_d, tau_J, tau_J_d, the force at K, the success rate)."""
    return (t, state["q"].copy(), state["q_d"].copy(), state["tau_J"].copy(),
            state["tau_J_d"].copy(), state["O_F_ext_hat_K"][:3].copy(),
            float(state["control_command_success_rate"]))


_PLOTS = (("q vs q_d (rad)", ("q", "q_d")), ("tau_J vs tau_J_d (Nm)", ("tau_J", "tau_J_d")),
          ("external force at K (N)", ("Fx", "Fy", "Fz")),
          ("command success rate", ("success rate",)))
# x is seconds, not a date (uPlot's default); y follows the data, except where every value is
# 0 (an arm at rest at joint angle 0, no external force), which uPlot would show on 0 to 100.
_SCALES = {"x": {"time": False, "auto": True}, "y": {"auto": True}}
_ZERO_SCALES = {"x": _SCALES["x"], "y": {"auto": False, "range": [-1.0, 1.0]}}
# The y axis as wide as a value like "-0.3865" needs (uPlot's 50 px cut off its sign).
_AXES = ({}, {"size": 64})


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
        self._status: tuple | None = None  # (mode, errors, reflex) last shown
        self._events: deque = deque(maxlen=EVENTS)
        self._gui = gui
        self._folder = gui.add_folder(f"arm {name}")
        with self._folder:
            self.mode = gui.add_text("robot mode", "no state yet", disabled=True)
            self.errors = gui.add_text("errors", "-", disabled=True)
            self.reflex = gui.add_text("last reflex", "none", disabled=True)
            self.success = gui.add_text("success rate", "-", disabled=True)
            self.q = gui.add_text("q (rad)", "-", disabled=True)
            self.wrench = gui.add_text("O_F_ext_hat_K", "-", disabled=True)
            self.events = gui.add_text("events", "", multiline=True, disabled=True)
            self.joint = gui.add_dropdown("joint", [str(j) for j in range(1, 8)],
                                          initial_value="1")
        # The plots are made with their first two points: a uPlot made empty keeps the empty
        # scale it started with (viser 1.1), whatever data follows.
        self.plots: tuple | None = None
        self._zero: tuple = ()  # each plot's: all its values 0 (its scale _ZERO_SCALES)

    def show(self, snapshot) -> None:
        """Readouts from the snapshot's state of this arm; the plots every PLOT_PERIOD."""
        read = self._read(snapshot)
        if read is None:
            return
        s, t, status = read
        self._note(status, t)
        rows = self._rows
        rows.append(row_of(s, t))
        while rows and rows[0][0] < t - WINDOW:
            rows.popleft()
        if snapshot.time - self._last_plot >= PLOT_PERIOD:
            self._last_plot = snapshot.time
            self._plot()

    def restart(self) -> None:
        """Plots and events from the next state on, timed from it: a page opened after
        everyone left starts its own history (its time axis from 0, not from the first page's
        first state)."""
        self._rows.clear()
        self._events.clear()
        self._t0, self._status, self._last_state, self._last_plot = None, None, None, 0.0

    def hold(self, now: float) -> None:
        """No state came since the last one shown, up to `now` (time.monotonic()): a paused
        clock sends none, the world having settled. The last state holds meanwhile, and the
        plots show it held (a watcher who comes to a paused server sees its one state drawn)."""
        rows = self._rows
        if not rows or now - self._last_plot < PLOT_PERIOD:
            return
        t = now - self._t0
        if t - rows[-1][0] < PLOT_PERIOD:
            return
        rows.append((t, *rows[-1][1:]))
        while rows and rows[0][0] < t - WINDOW:
            rows.popleft()
        self._last_plot = now
        self._plot()

    def show_recorded(self, snapshot, rows: list, events: list[str], reflex: str) -> None:
        """A recording's moment: the readouts as `show` gives them, the plots' rows, the events
        and the last reflex up to it as recorded (`rows`, `events`, `reflex`), not as shown
        before: a scrubbed timeline shows its moments in any order. The state may be the one
        shown last (the arm's last before a later moment): its rows and events still change."""
        states = snapshot.states
        if self.index >= len(states) or states[self.index] is None:
            return
        self._read(snapshot)
        self.reflex.value = reflex
        self._rows = deque(rows)
        self._events = deque(events, maxlen=EVENTS)
        self.events.value = "\n".join(reversed(self._events))  # newest first
        self._plot(until=snapshot.time - self._t0)

    def _read(self, snapshot):
        """(state, t, status) of this arm's state in the snapshot, its readouts set; None if
        it holds none, or the one shown last."""
        states = snapshot.states
        data = states[self.index] if self.index < len(states) else None
        if data is None or data is self._last_state:
            return None
        self._last_state = data
        s = decode_state(data)
        if self._t0 is None:
            self._t0 = snapshot.time
        t = snapshot.time - self._t0
        status = status_of(s)
        mode, errors, reflex = status
        self.mode.value, self.errors.value = mode, errors
        if reflex != "none":
            self.reflex.value = reflex
        self.success.value = f"{float(s['control_command_success_rate']):.3f}"
        self.q.value = numbers(s["q"])
        self.wrench.value = numbers(s["O_F_ext_hat_K"])
        return s, t, status

    def _note(self, status: tuple, t: float) -> None:
        """A line in `events` each time the mode, the errors or the reflex's reasons change (as
        seen ~30 times a second: a change undone within 30 ms may go unseen)."""
        if status == self._status:
            return
        before, self._status = self._status, status
        self._events.append(event_line(before, status, t))
        self.events.value = "\n".join(reversed(self._events))  # newest first

    def _plot(self, until: float | None = None) -> None:
        """The plots of `rows`; with fewer than two, those of a recording's moment (`until`)
        show its window empty (not the curves of the moment shown before)."""
        rows, j = self._rows, int(self.joint.value) - 1
        if len(rows) < 2:
            if self.plots is not None and until is not None:  # (a gap, not no data at all:
                gap = (np.array([until - WINDOW, until]), np.full(2, np.nan))  # see above)
                for plot, (_, labels) in zip(self.plots, _PLOTS):
                    plot.data = gap + gap[1:] * (len(labels) - 1)
            return
        t = np.array([r[0] for r in rows])
        forces = np.array([r[5] for r in rows]).reshape(-1, 3)
        data = ((t, np.array([r[1][j] for r in rows]), np.array([r[2][j] for r in rows])),
                (t, np.array([r[3][j] for r in rows]), np.array([r[4][j] for r in rows])),
                (t, forces[:, 0], forces[:, 1], forces[:, 2]),
                (t, np.array([r[6] for r in rows])))
        zero = tuple(not any(np.any(v) for v in values[1:]) for values in data)
        if self.plots is None:
            self.plots = tuple(self._add_plot(values, spec, flat, None)
                               for values, spec, flat in zip(data, _PLOTS, zero))
            self._zero = zero
            return
        plots = list(self.plots)
        for k, (values, flat, was) in enumerate(zip(data, zero, self._zero)):
            if flat != was:  # another y scale: a plot of its own in the same place
                plots[k] = self._add_plot(values, _PLOTS[k], flat, plots[k].order)
                self.plots[k].remove()
            else:
                plots[k].data = values
        self.plots, self._zero = tuple(plots), zero

    def _add_plot(self, values, spec, flat: bool, order: float | None):
        """A uPlot, its y scale _ZERO_SCALES where `flat`. (Not a new `scales` on the one
        there: viser 1.1's uPlot then keeps its time axis where it was, the data moving on.)"""
        title, labels = spec
        with self._folder:
            return self._gui.add_uplot(values, _series(*labels), title=title, aspect=2.0,
                                       scales=_ZERO_SCALES if flat else _SCALES, axes=_AXES,
                                       order=order)
