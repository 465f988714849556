"""`franka-sim replay | plot | render | view`: the commands that read a recording (cli.py
registers `COMMANDS` on its app; this module imports nothing of the CLI's)."""

from __future__ import annotations

import json

from pathlib import Path

import typer


# render's and view's --meshes (one option, as serve's)
MESHES = typer.Option(
    None, envvar="FRANKA_SIM_MESHES", exists=True, file_okay=False, metavar="DIR",
    help="Draw the arms with the visual meshes of the franka_description at DIR (as "
    "serve --meshes).",
)


def _open(path: Path, extra: str = "record"):
    """The recording at `path`, or its one-line error and exit 1 (naming `extra`, the extra the
    command needs: it brings mcap too)."""
    from franka_sim.recording import mcap_missing

    if missing := mcap_missing(extra):
        typer.echo(f"franka-sim: {missing}", err=True)
        raise typer.Exit(1)
    from franka_sim.recording.reader import RecordingError, open_recording

    try:
        return open_recording(path)
    except RecordingError as exc:
        typer.echo(f"franka-sim: {exc}", err=True)
        raise typer.Exit(1) from None


def replay(
    recording: Path = typer.Argument(..., metavar="RECORDING", help="An MCAP file from "
                                     "`franka-sim serve --record`."),
    until: int | None = typer.Option(None, min=0, help="Compare up to this cycle only."),
) -> None:
    """Run a recording again in a fresh simulator and compare every state, bit for bit: prints
    `identical (N cycles[, M tool states])`, or the first cycle that differs and its fields
    (exit 1)."""
    import logging

    from franka_sim.recording.metadata import Incompatible
    from franka_sim.playback.replay import replay as run_replay

    # The replayed run's warnings are the recorded run's (its /log channel has them): said
    # again after the verdict, they would read as the replay's own.
    logging.getLogger("franka_sim").setLevel(logging.ERROR)
    loaded = _open(recording)
    try:
        outcome = run_replay(loaded, until)
    except Incompatible as exc:
        typer.echo(f"franka-sim: {recording}: {exc}", err=True)
        raise typer.Exit(1) from None
    typer.echo(outcome.line())
    if not outcome.identical:
        from franka_sim.recording.numerics import differences

        recorded = loaded.metadata.get("numerics")
        if recorded and (differ := differences(json.loads(recorded))):
            typer.echo(f"recorded with other numerical kernels ({'; '.join(differ)}): their "
                       "last bits differ, and so does a replay (docs/recording.md, Across "
                       "machines)")
        elif not recorded:
            typer.echo("the recording does not say which numerical kernels it ran on (an "
                       "older one): on another machine or OpenBLAS core their last bits differ, "
                       "and so does a replay (docs/recording.md, Across machines)")
        raise typer.Exit(1)


def plot(
    recording: Path = typer.Argument(..., metavar="RECORDING"),
    output: Path = typer.Option(..., "-o", "--output", dir_okay=False,
                                help="The image to write: .png, .pdf, .svg or .jpg (no suffix: "
                                "PNG)."),
    joints: str | None = typer.Option(None, help="Joints to draw, e.g. 1,4 (default: all)."),
    start: float | None = typer.Option(None, "--from", help="From this robot time \\[s]."),
    end: float | None = typer.Option(None, "--to", help="To this robot time \\[s]."),
    fields: str | None = typer.Option(
        None, help="More RobotState fields, one panel each, e.g. elbow,O_dP_EE_d."),
    robot: str | None = typer.Option(
        None, help="The robot to draw, by name, in a recording of several (default: the first "
        "that sent a state)."),
) -> None:
    """Draw a recording: q vs q_d, dq, tau_J vs tau_J_d, the external wrench, the success
    rate, the robot mode with motions and errors, and the Hand's width (needs
    franka-sim\\[plot])."""
    from franka_sim.playback.plot import PlotError, output_format, parse_fields, parse_joints
    from franka_sim.playback.plot import plot as draw
    from franka_sim.recording.reader import RecordingError

    try:
        output_format(output)
        chosen, extra = parse_joints(joints), parse_fields(fields)
        loaded = _open(recording, "plot")
        draw(loaded, output, joints=chosen, start=start, end=end, fields=extra, robot=robot)
    except (PlotError, RecordingError) as exc:
        typer.echo(f"franka-sim: {exc}", err=True)
        raise typer.Exit(1) from None
    except OSError as exc:
        typer.echo(f"franka-sim: cannot write {output}: {exc.strerror or exc}", err=True)
        raise typer.Exit(1) from None


def render(
    recording: Path = typer.Argument(..., metavar="RECORDING"),
    output: Path = typer.Option(..., "-o", "--output", dir_okay=False,
                                help="The video to write: .mp4, .mkv, .mov or .avi."),
    camera: str | None = typer.Option(None, help="A camera of the scene, by name."),
    fps: float = typer.Option(30.0, min=1.0, max=240.0, help="Frames per second of robot time."),
    meshes: Path | None = MESHES,
) -> None:
    """Make a video of a recording without a screen (MuJoCo offscreen through EGL or OSMesa;
    needs franka-sim\\[render])."""
    from franka_sim.playback.render import RenderError, import_mujoco_with_gl
    from franka_sim.playback.render import render as make_video

    try:
        import_mujoco_with_gl()  # (before anything below imports mujoco)
    except RenderError as exc:
        typer.echo(f"franka-sim: {exc}", err=True)
        raise typer.Exit(1) from None
    from franka_sim.physics.scene import SceneError

    loaded = _open(recording, "render")
    try:
        frames = make_video(loaded, output, fps=fps, camera=camera, meshes=meshes)
    except (RenderError, SceneError) as exc:  # (SceneError: --meshes)
        typer.echo(f"franka-sim: {exc}", err=True)
        raise typer.Exit(1) from None
    typer.echo(f"{output}: {frames} frames")


def view(
    recording: Path = typer.Argument(..., metavar="RECORDING"),
    host: str = typer.Option("127.0.0.1", help="Address to serve the page on."),
    port: int = typer.Option(8080, min=1, max=65535, help="Port to serve the page on."),
    meshes: Path | None = MESHES,
) -> None:
    """Watch a recording in a browser: the world in 3D with a timeline to scrub or play, and
    each arm's readouts and plots (docs/viewing.md; needs franka-sim\\[web]). Until Ctrl-C."""
    from franka_sim.web import web_missing

    if missing := web_missing():
        typer.echo(f"franka-sim: {missing}", err=True)
        raise typer.Exit(1)
    from franka_sim.physics.scene import SceneError
    from franka_sim.recording.metadata import Incompatible
    from franka_sim.web.recording_view import serve_recording

    loaded = _open(recording, "web")
    try:
        serve_recording(loaded, host, port, meshes)
    except Incompatible as exc:
        typer.echo(f"franka-sim: {recording}: {exc}", err=True)
        raise typer.Exit(1) from None
    except SceneError as exc:  # --meshes
        typer.echo(f"franka-sim: {exc}", err=True)
        raise typer.Exit(1) from None
    except OSError as exc:
        typer.echo(f"franka-sim: {exc.strerror or exc}", err=True)
        raise typer.Exit(1) from None


COMMANDS = (replay, plot, render, view)  # cli.py registers them on its app, in this order
