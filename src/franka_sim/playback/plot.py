"""`franka-sim plot`: what happened in a recording, as one PNG of stacked panels on the robot's
clock (seconds = cycles / 1000): q against q_d, dq, tau_J against tau_J_d, the external wrench,
the success rate, a timeline of the robot mode with motions, errors and lost cycles, and the
tool's state (the Hand's width, the vacuum) where its client took states; for the mobile base
its pose and twist in place of the joints'; every panel marks where motions started (solid)
and ended (dashed). matplotlib is an optional extra."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from franka_sim.protocol.codec import STATE_DTYPE
from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.recording.reader import Recording
from franka_sim.playback.timeline import (
    error_onsets,
    lost_cycles,
    mode_names,
    motion_ends,
    motion_starts,
)

WIDTH, PANEL_HEIGHT, DPI = 12.0, 2.2, 100  # inches, inches per panel, dots per inch
# The least span a panel's axis shows, in its unit: an arm at rest trembles by ~1e-9 rad, which
# drawn at full scale (with an offset such as "1e-9 +7.854e-1") looks like a motion.
LEAST_SPAN = {"q": 1e-3, "dq": 1e-3, "tau": 1e-2, "wrench": 1e-2, "gripper_state": 1e-3,
              "base pose": 1e-3, "base twist": 1e-3}
TOOL_PANELS = {"gripper_state": "Hand", "vacuum_gripper_state": "vacuum gripper"}
ARM_PANELS = ("q", "dq", "tau", "wrench", "success", "timeline")
# The mobile base's (robot/base_state.py): its planar pose and its body twist.
BASE_PANELS = ("base pose", "base twist", "success", "timeline")
LEGENDS = ("q", "dq", "tau", "wrench", "base pose", "base twist")


class PlotError(Exception):
    """Bad options (an unknown field, a joint out of 1-7, an empty window): one line."""


class MissingExtra(PlotError):
    pass


# The image formats `plot` writes, by the output's suffix (none: PNG, at the path as given).
FORMATS = {".png": "png", ".pdf": "pdf", ".svg": "svg", ".jpg": "jpeg", ".jpeg": "jpeg"}


def output_format(output: Path) -> str:
    """The format `output`'s suffix names (PlotError for one matplotlib would refuse only once
    the whole figure is drawn)."""
    suffix = output.suffix.lower()
    if suffix and suffix not in FORMATS:
        raise PlotError(f"{output}: a plot is written as {', '.join(sorted(FORMATS))} "
                        f"(or PNG without a suffix), not {suffix}")
    return FORMATS.get(suffix, "png")


def parse_joints(text: str | None) -> list[int] | None:
    """--joints as 0-based indices; None: not given (every joint of an arm)."""
    if not text:
        return None
    try:
        joints = [int(part) for part in text.split(",")]
    except ValueError:
        raise PlotError(f"--joints {text!r}: joint numbers 1-7, comma-separated") from None
    if not all(1 <= j <= 7 for j in joints):
        raise PlotError(f"--joints {text!r}: joints are numbered 1 to 7")
    return [j - 1 for j in joints]


def parse_fields(text: str | None) -> list[str]:
    fields = [f for f in (text or "").split(",") if f]
    for name in fields:
        if name not in STATE_DTYPE.names:
            raise PlotError(f"--fields: RobotState has no field {name!r}")
    return fields


def plot(recording: Recording, output: Path, *, joints: list[int] | None = None,
         start: float | None = None,
         end: float | None = None, fields: list[str] = (), robot: str | None = None) -> int:
    """Write the PNG of one robot (None: the first that sent a state); the number of panels."""
    fig = figure(recording, joints=joints, start=start, end=end, fields=fields, robot=robot)
    fig.savefig(output, dpi=DPI, format=output_format(output))
    import matplotlib.pyplot as plt

    plt.close(fig)
    return len(fig.axes)


def figure(recording: Recording, *, joints: list[int] | None = None, start: float | None = None,
           end: float | None = None, fields: list[str] = (), robot: str | None = None):
    """The figure `plot` writes (matplotlib's)."""
    try:
        import matplotlib
    except ImportError:
        raise MissingExtra("plotting needs matplotlib: pip install 'franka-sim[plot]'") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if start is not None and end is not None and start > end:
        raise PlotError(f"--from {start:g} is after --to {end:g}")
    if robot is None:  # (a world whose first arm had no client: its base's, say)
        robot = next((name for name in recording.robots if recording.of("robot_state", name)
                      or recording.tool_states(name) is not None), None)
    if recording.kind(robot) == "base" and joints is not None:
        raise PlotError("--joints: the mobile base has no joints (its panels are its pose and "
                        "its twist)")
    joints = list(range(7)) if joints is None else joints
    states = recording.states(robot)
    tool = recording.tool_states(robot)
    if not len(states) and tool is None:
        sent = [name for name in recording.robots if name != robot
                and (recording.of("robot_state", name) or recording.tool_states(name) is not None)]
        if sent:
            raise PlotError(f"robot {robot!r} sent no state (--robot {sent[0]} did)")
        raise PlotError("no robot or tool state recorded: nothing to plot")
    if not len(states) and fields:
        raise PlotError("--fields: no arm state recorded (only its tool's)")
    states, t = _in_window(states, start, end)
    if tool is not None:
        tool = (tool[0], *_in_window(tool[1], start, end))
    if not len(t) and (tool is None or not len(tool[2])):
        raise PlotError("no state in the window --from/--to")
    if not len(t) and fields:
        raise PlotError("--fields: no arm state in the window --from/--to (only its tool's)")
    times = np.concatenate([t, tool[2] if tool is not None else []])
    window = (times.min(), times.max())
    cut = _breaks(states["message_id"])
    tc = cut(t)

    own = BASE_PANELS if recording.kind(robot) == "base" else ARM_PANELS
    panels = list(own) if len(t) else []
    panels += [tool[0]] if tool is not None and len(tool[2]) else []
    panels += fields
    fig, axes = plt.subplots(len(panels), 1, sharex=True, squeeze=False,
                             figsize=(WIDTH, PANEL_HEIGHT * len(panels)), dpi=DPI)
    axes = axes[:, 0]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for ax, panel in zip(axes, panels):
        if panel == "q":
            for j in joints:
                c = colors[j % len(colors)]
                ax.plot(tc, cut(states["q"][:, j]), color=c, label=f"q{j + 1}")
                ax.plot(tc, cut(states["q_d"][:, j]), color=c, ls=":", label=f"q_d{j + 1}")
            ax.set_ylabel("q, q_d [rad]")
        elif panel == "dq":
            for j in joints:
                ax.plot(tc, cut(states["dq"][:, j]), color=colors[j % len(colors)],
                        label=f"dq{j + 1}")
            ax.set_ylabel("dq [rad/s]")
        elif panel == "tau":
            for j in joints:
                c = colors[j % len(colors)]
                ax.plot(tc, cut(states["tau_J"][:, j]), color=c, label=f"tau_J{j + 1}")
                ax.plot(tc, cut(states["tau_J_d"][:, j]), color=c, ls=":", label=f"tau_J_d{j + 1}")
            ax.set_ylabel("tau_J, tau_J_d [Nm]")
        elif panel == "wrench":
            for i, name in enumerate(("Fx", "Fy", "Fz", "Tx", "Ty", "Tz")):
                ax.plot(tc, cut(states["O_F_ext_hat_K"][:, i]), label=name)
            ax.set_ylabel("O_F_ext_hat_K")
        elif panel == "base pose":  # (O_T_EE column-major: x, y at 12, 13; cos, sin at 0, 1)
            pose = states["O_T_EE"]
            ax.plot(tc, cut(pose[:, 12]), label="x [m]")
            ax.plot(tc, cut(pose[:, 13]), label="y [m]")
            ax.plot(tc, cut(np.arctan2(pose[:, 1], pose[:, 0])), label="yaw [rad]")
            ax.set_ylabel("base pose")
        elif panel == "base twist":  # moved at (O_dP_EE_d) and commanded (O_dP_EE_c)
            for c, (i, name) in zip(colors, ((0, "vx"), (1, "vy"), (5, "wz"))):
                ax.plot(tc, cut(states["O_dP_EE_d"][:, i]), color=c, label=name)
                ax.plot(tc, cut(states["O_dP_EE_c"][:, i]), color=c, ls=":", label=f"{name}_c")
            ax.set_ylabel("twist [m/s, rad/s]")
        elif panel == "success":
            ax.plot(tc, cut(states["control_command_success_rate"]), color="k")
            ax.set_ylim(-0.05, 1.05)
            ax.set_ylabel("success rate")
        elif panel == "timeline":
            _timeline(ax, recording, states, t, window, robot, cut)
        elif panel in TOOL_PANELS:
            _tool(ax, panel, *tool[1:])
        else:
            values = np.asarray(states[panel], dtype=float).reshape(len(t), -1)
            ax.plot(tc, cut(values))
            ax.set_ylabel(panel)
        if panel in LEGENDS and len(ax.get_lines()) <= 14:
            ax.legend(loc="upper right", fontsize=6, ncol=7)
        if panel != "timeline":
            _readable(ax, LEAST_SPAN.get(panel, 0.0))
        _boundaries(ax, recording, window, robot)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("robot time [s] (message_id × 1 ms)")
    counted = [f"{len(states)} states"] if len(t) else []
    counted += [f"{len(tool[1])} {TOOL_PANELS[tool[0]]} states"] if tool is not None else []
    whose = f" of {robot}" if len(recording.robots) > 1 else ""  # (which robot of several)
    axes[0].set_title(f"{recording.path.name}: {', '.join(counted)}{whose}")
    fig.tight_layout()
    return fig


def _in_window(states, start: float | None, end: float | None):
    """(states, their robot times) from `start` to `end` (s; None: no bound)."""
    t = states["message_id"].astype(float) * CYCLE_PERIOD
    keep = np.ones(len(t), bool)
    if start is not None:
        keep &= t >= start
    if end is not None:
        keep &= t <= end
    return states[keep], t[keep]


def _tool(ax, key: str, states, t) -> None:
    """The Hand's width (and its opening) with where it held a grasp; the vacuum gripper's
    vacuum with where a part was present. Each state is marked: in lockstep an action's
    result is often a state with no neighbour, which a line alone would not draw."""
    ids = states["message_id"].astype(np.int64)
    cut = _breaks(ids, int(np.diff(ids).min()) if len(ids) > 1 else 1)  # (its state period)
    if key == "gripper_state":
        ax.plot(cut(t), cut(states["width"]), color="k", marker=".", label="width")
        ax.plot(cut(t), cut(states["max_width"]), color="k", ls=":", label="max_width")
        held, label = states["is_grasped"], "is_grasped"
        ax.set_ylabel("Hand width [m]")
    else:
        ax.plot(cut(t), cut(states["vacuum"]), color="k", marker=".", label="vacuum")
        held, label = states["part_present"], "part_present"
        ax.set_ylabel("vacuum [mbar below ambient]")
    if held.any():
        ax.fill_between(t, 0, 1, where=held, step="post", color="tab:green", alpha=0.2,
                        transform=ax.get_xaxis_transform(), label=label)
    ax.legend(loc="upper right", fontsize=6)


def _breaks(message_ids, period: int = 1):
    """A function that puts a NaN wherever states were not sent between two recorded ones (a
    lockstep world settling, a clock paused), so that no line is drawn across what no state
    said; `period`: the cycles between two states of the stream."""
    gaps = np.flatnonzero(np.diff(np.asarray(message_ids, dtype=np.int64)) > period) + 1

    def cut(values):
        return np.insert(np.asarray(values, dtype=float), gaps, np.nan, axis=0)

    return cut


def _readable(ax, least: float) -> None:
    """The values on the axis as they are (no offset), over at least `least` around them."""
    ax.ticklabel_format(axis="y", useOffset=False)
    values = [line.get_ydata() for line in ax.get_lines()]
    values = np.concatenate(values) if values else np.empty(0)
    values = values[np.isfinite(values)]
    if least and len(values) and values.max() - values.min() < least:
        middle = 0.5 * (values.max() + values.min())
        ax.set_ylim(middle - 0.5 * least, middle + 0.5 * least)


def _boundaries(ax, recording: Recording, window, robot) -> None:
    for mark in motion_starts(recording, robot):
        if window[0] <= mark.cycle * CYCLE_PERIOD <= window[1]:
            ax.axvline(mark.cycle * CYCLE_PERIOD, color="g", lw=0.8)
    for mark in motion_ends(recording, robot):
        if window[0] <= mark.cycle * CYCLE_PERIOD <= window[1]:
            ax.axvline(mark.cycle * CYCLE_PERIOD, color="g", lw=0.8, ls="--")


def _timeline(ax, recording: Recording, states, t, window, robot, cut) -> None:
    names = mode_names()
    modes = states["robot_mode"].astype(int)
    ax.step(cut(t), cut(modes), where="post", color="k")  # (no mode drawn where none was sent)
    shown = sorted(set(modes.tolist()) | {1, 2, 4})
    ax.set_yticks(shown, [names.get(m, str(m)) for m in shown])
    ax.set_ylabel("robot mode")
    for mark in error_onsets(states):
        x = mark.cycle * CYCLE_PERIOD
        ax.axvline(x, color="r", lw=1)
        ax.annotate(mark.label, (x, 0.95), xycoords=("data", "axes fraction"), rotation=90,
                    fontsize=6, va="top", color="r")
    for mark in motion_starts(recording, robot):
        x = mark.cycle * CYCLE_PERIOD
        if window[0] <= x <= window[1]:
            ax.annotate(mark.label, (x, 0.05), xycoords=("data", "axes fraction"),
                        rotation=90, fontsize=6, va="bottom", color="g")
    lost = [m for m in lost_cycles(recording, robot)
            if window[0] <= m.cycle * CYCLE_PERIOD <= window[1]]
    for extrapolated, color, label in ((True, "tab:orange", "lost: extrapolated"),
                                       (False, "tab:red", "lost: held, braked, ...")):
        xs = [m.cycle * CYCLE_PERIOD for m in lost if (m.label == "extrapolated") == extrapolated]
        if xs:
            ax.plot(xs, [-0.5] * len(xs), "|", color=color, markersize=8, label=label)
    if lost:
        ax.legend(loc="upper right", fontsize=6)
