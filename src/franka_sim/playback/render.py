"""`franka-sim render`: a video of a recording without a screen, from its states' joint angles
and the world's recorded poses (MuJoCo offscreen through EGL, or OSMesa: MUJOCO_GL).

Frames are taken on the robot's clock, one every 1/fps s of cycles, of the world as the
recording had it then (playback/recorded_world.py: every arm at its state sent nearest that
cycle, the free bodies and the Hand's fingers at the last pose record before it, the mobile
base where its states put it). imageio-ffmpeg (the `render` extra) writes the video.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from franka_sim.protocol.timing import CYCLE_PERIOD
from franka_sim.recording.reader import Recording

WIDTH, HEIGHT = 640, 480
BACK_OFF = 1.3  # the free camera's distance, as a multiple of the first view's
VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov", ".avi")  # what ffmpeg writes with H.264


class RenderError(Exception):
    """One line: what is missing to render."""


def _no_gl(exc: Exception) -> RenderError:
    return RenderError(f"no offscreen OpenGL (MUJOCO_GL={os.environ.get('MUJOCO_GL')}: "
                       f"{exc}); install libegl1 (or libosmesa6 with MUJOCO_GL=osmesa)")


def import_mujoco_with_gl():
    """mujoco, with the offscreen GL that MUJOCO_GL names (egl if unset): with osmesa, its
    import is where a missing libOSMesa shows."""
    if os.environ.get("MUJOCO_GL", "disable") == "disable":  # (the server's: no GL)
        os.environ["MUJOCO_GL"] = "egl"  # before mujoco is imported in this process
    try:
        import mujoco
    except Exception as exc:  # noqa: BLE001 - PyOpenGL without its library fails oddly
        raise _no_gl(exc) from None
    return mujoco


def check_output(output: Path) -> None:
    """RenderError unless a video can be written at `output` (before any frame is drawn)."""
    if output.suffix.lower() not in VIDEO_SUFFIXES:
        raise RenderError(f"cannot write {output}: a video is {', '.join(VIDEO_SUFFIXES)}")
    if not output.parent.is_dir():
        raise RenderError(f"cannot write {output}: no directory {output.parent}")
    if not os.access(output.parent, os.W_OK):
        raise RenderError(f"cannot write {output}: {output.parent} is not writable")


def frame_cycles(first: int, last: int, fps: float) -> np.ndarray:
    """The cycles a video of `fps` frames per second of robot time shows."""
    step = 1.0 / (fps * CYCLE_PERIOD)
    return np.round(first + np.arange(int((last - first) / step) + 1) * step).astype(int)


class Frames:
    """A recording's video frames, drawn on demand: `model` (its world's), `cycles` (which
    cycle each frame shows), and iterating gives each frame as an (HEIGHT, WIDTH, 3) uint8
    array, or with `segmentation` the (object id, object type) of each pixel (which geom it
    shows: the arm's look is tested that way)."""

    def __init__(self, recording: Recording, *, fps: float = 30.0, camera: str | None = None,
                 segmentation: bool = False, meshes: Path | None = None) -> None:
        mujoco = import_mujoco_with_gl()
        # (MuJoCo's importers: after its GL is set)
        from franka_sim.playback.recorded_world import RecordedWorld, recorded_physics
        from franka_sim.recording.metadata import Incompatible

        try:
            with tempfile.TemporaryDirectory(prefix="franka-sim-render-") as workdir:
                # (meshes: how it is drawn, never part of a recording)
                _, _, physics = recorded_physics(recording, workdir, meshes)
            self.model, self.data = physics.world.model, physics.world.data
            self._world = RecordedWorld(recording, physics)
        except Incompatible as exc:  # (nothing to show, or no world to show it in)
            raise RenderError(f"{recording.path}: {exc}") from None
        self._world.put(self.data, self._world.first)  # (the camera frames the start)
        mujoco.mj_forward(self.model, self.data)
        self._camera = _camera(self.model, self.data, camera)
        try:
            self._renderer = mujoco.Renderer(self.model, HEIGHT, WIDTH)
        except Exception as exc:  # noqa: BLE001 - no GL context: say which way to get one
            raise _no_gl(exc) from None
        if segmentation:
            self._renderer.enable_segmentation_rendering()
        self.cycles = frame_cycles(self._world.first, self._world.last, fps)

    def __iter__(self):
        import mujoco

        model, data, renderer = self.model, self.data, self._renderer
        for n in self.cycles:
            self._world.put(data, n)
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera=self._camera)
            yield np.ascontiguousarray(renderer.render())

    def close(self) -> None:
        self._renderer.close()


def render(recording: Recording, output: Path, *, fps: float = 30.0,
           camera: str | None = None, meshes: Path | None = None) -> int:
    """Write the video; the number of frames."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RenderError("rendering needs imageio-ffmpeg: pip install 'franka-sim[render]'") \
            from None
    check_output(output)
    frames = Frames(recording, fps=fps, camera=camera, meshes=meshes)
    writer = imageio_ffmpeg.write_frames(str(output), (WIDTH, HEIGHT), fps=fps,
                                         macro_block_size=1, quality=6)
    try:
        writer.send(None)
        for frame in frames:
            writer.send(frame)
        writer.close()
    except (OSError, RuntimeError) as exc:  # ffmpeg refused or died: its own words
        raise RenderError(f"cannot write {output}: {str(exc).strip().splitlines()[-1]}") \
            from None
    finally:
        frames.close()
    return len(frames.cycles)


def _camera(model, data, name: str | None):
    """A camera of the model by name, or the first view of every arm (physics/first_view.py)
    of `data` (forward-computed) as a free camera, a little further back (a video is smaller
    than a window)."""
    import mujoco

    from franka_sim.physics.first_view import aim

    if name is not None:
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name) < 0:
            names = [model.camera(i).name for i in range(model.ncam)]
            raise RenderError(f"--camera {name!r}: the scene has no such camera "
                              f"(it has: {', '.join(names) or 'none'})")
        return name
    cam = mujoco.MjvCamera()
    aim(cam, model, data, BACK_OFF)
    return cam
