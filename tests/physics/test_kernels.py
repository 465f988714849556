"""The cycle's kernels: the compiled module gives its numpy reference's bits for every input
(hypothesis draws them), the simulator gives the same states on either (recordings replay
identical on the reference), and `pip` builds the module where there is a compiler and a pure
wheel where there is none.

The compiled half needs the module built (a C compiler at install time, as .ci/run has); without
it those tests skip, saying so, and the reference is what runs everywhere.
"""

from __future__ import annotations

import inspect
import os
import shutil
import struct
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from franka_sim import kernels
from franka_sim.kernels import reference
from franka_sim.testing import ServerProcess, fresh_loopback_address
from support.replayed import replay_committed

REPO = Path(__file__).resolve().parents[2]
RECORDINGS = Path(__file__).resolve().parents[1] / "data" / "older_libfranka" / "0.21.2"

try:
    from franka_sim.kernels import _compiled as compiled
except ImportError:
    compiled = None
needs_compiled = pytest.mark.skipif(
    compiled is None, reason="franka_sim.kernels._compiled is not built (no C compiler at "
    "install time): the numpy reference runs")

# Finite doubles over many magnitudes, signed zeros included (what a cycle meets).
FINITE = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6) | \
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e-9])
ANY = st.floats(allow_nan=True, allow_infinity=True, width=64)
POSITIVE = st.floats(min_value=1e-6, max_value=1e3)


def vec(n: int, elements=FINITE):
    return arrays(np.float64, n, elements=elements)


def same_bits(a, b) -> bool:
    return np.asarray(a).tobytes() == np.asarray(b).tobytes()


def run_both(name: str, *args, outputs: tuple[int, ...]):
    """Call kernel `name` of both modules on copies of `args`; (both returns, both sets of the
    arrays at `outputs`)."""
    copies = [[a.copy() if isinstance(a, np.ndarray) else a for a in args] for _ in range(2)]
    with np.errstate(all="ignore"):  # drawn infinities and NaNs: what matters is the bits
        results = [getattr(module, name)(*c) for module, c in zip((compiled, reference), copies)]
    return results, [[c[i] for i in outputs] for c in copies]


def assert_same(name: str, *args, outputs: tuple[int, ...]) -> None:
    (got, want), (got_out, want_out) = run_both(name, *args, outputs=outputs)
    assert got == want
    for g, w in zip(got_out, want_out):
        assert same_bits(g, w), f"{name}: {g} != {w}"


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(7), vec(7), POSITIVE, vec(7))
def test_drive_follow(applied, ff, tau_ff, step, gcomp):
    assert_same("drive_follow", applied, ff, tau_ff, step, gcomp, outputs=(0, 1))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(7), vec(7), POSITIVE, vec(7), st.lists(vec(7), min_size=6, max_size=6))
def test_drive_impedance(applied, ff, tau_ff, step, gcomp, rest):
    assert_same("drive_impedance", applied, ff, tau_ff, step, gcomp, *rest, outputs=(0, 1))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7, ANY), vec(7), vec(7), vec(7))
def test_saturate_less(applied, tau_max, tau_min, friction):
    assert_same("saturate_less", applied, tau_max, tau_min, friction, outputs=(0,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(14), vec(14), POSITIVE, POSITIVE)
def test_torque_inside(tau, last, effort, threshold, dt):
    assert_same("torque_inside", tau, last, np.zeros(14), effort, threshold, dt, outputs=(2,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7, ANY), vec(7, ANY), vec(28), vec(28))
def test_measured_inside(q, dq, offsets, thresholds):
    assert_same("measured_inside", q, dq, offsets, thresholds, outputs=())


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(14), vec(14), vec(14), POSITIVE, POSITIVE, POSITIVE, vec(14), vec(56))
def test_joint_position_step(q_c, q, v, a, s1, s2, s3, floor_limits, thresholds):
    assert_same("joint_position_step", q_c, q, v, a, s1, s2, s3, floor_limits, thresholds,
                np.zeros(56), outputs=(9,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7, ANY), vec(7), vec(7), vec(7))
def test_friction_loops(x, phi3, half_phi2, at_rest):
    assert_same("friction_argument", x, phi3, half_phi2, np.zeros(7), outputs=(3,))
    assert_same("friction_torque", x, at_rest, half_phi2, np.zeros(7), outputs=(3,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(7), vec(7), vec(7))
def test_add_feed_forward(out, a, b, c):
    assert_same("add_feed_forward", out, a, b, c, outputs=(0,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(vec(7), min_size=6, max_size=6), st.sampled_from([np.float64, np.float32]))
def test_impedance_torque_into_a_float64_or_a_state_field(inputs, dtype):
    assert_same("impedance_torque", *inputs, np.zeros(7, dtype), outputs=(6,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(vec(7), vec(7), vec(7), POSITIVE)
def test_joint_follow(q_c, q_d, dq_d, dt):
    assert_same("joint_follow", q_c, q_d, dq_d, dt, np.zeros(21), outputs=(4,))


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(ANY, min_size=45, max_size=45), st.sampled_from([1e6, sys.float_info.max]))
def test_doubles_within_a_command(values, bound):
    """The RobotCommand's two runs of doubles (q_c … elbow_c, tau_J_d), any values."""
    record = bytearray(371)
    struct.pack_into("<38d", record, 8, *values[:38])
    struct.pack_into("<7d", record, 314, *values[38:])
    runs = ((8, 38), (314, 7))
    assert compiled.doubles_within(record, runs, bound) is \
        reference.doubles_within(record, runs, bound)
    with pytest.raises(ValueError, match="outside"):
        compiled.doubles_within(record, ((314, 8),), bound)


@needs_compiled
@settings(max_examples=300, deadline=None)
@given(st.lists(vec(7, ANY | st.sampled_from([3.5e38, -3.5e38, 1e-46])), min_size=6, max_size=6),
       vec(18, ANY))
def test_narrow_into_a_states_float32_fields(sevens, eighteen):
    """A Measured's arrays into a state's fields: float32, rounded (overflowing to ±inf, NaN
    kept) as numpy casts; an (6, 3) accelerometer into its (6, 3) view."""
    sources = (*sevens, eighteen.reshape(6, 3))
    results = []
    for module in (compiled, reference):
        targets = (*(np.zeros(7, np.float32) for _ in range(6)),
                   np.zeros(18, np.float32).reshape(6, 3))
        with np.errstate(all="ignore"):
            module.narrow_into(targets, sources)
        results.append(b"".join(t.tobytes() for t in targets))
    assert results[0] == results[1]
    with pytest.raises(ValueError, match="a target of 7 values for a source of 6"):
        compiled.narrow_into((np.zeros(7, np.float32),), (np.zeros(6),))


@needs_compiled
@settings(max_examples=100, deadline=None)
@given(st.data())
def test_readings(data):
    """Both bound to arrays of the real layout's sizes; the step's values and the previous
    [tau_J, theta] drawn; the work arrays and the gathered output compared."""
    nsensor = 12
    work_size = 64 + 16 + 6 * 15 + nsensor
    gather = data.draw(st.lists(st.integers(0, work_size - 1), min_size=1, max_size=200))
    inputs = {name: data.draw(vec(n)) for name, n in (
        ("applied", 7), ("armature", 7), ("friction", 7), ("q", 7), ("dq", 7), ("mat", 9),
        ("pos", 3), ("sensordata", nsensor), ("ddq", 7))}
    stiffness = np.full(7, 7000.0)
    timesteps = np.full(15, 0.001)
    previous = data.draw(vec(15))
    first = data.draw(st.booleans())
    gathered = []
    for module in (compiled, reference):
        work = np.zeros(work_size)
        work[16:23] = inputs["ddq"]
        views = (work[16:23], work[24:31], work[32:39], work[24:39], work[40:55], work[0:7],
                 work[8:15], work[64:73], work[73:76], work[work_size - nsensor:])
        bound = module.bind_readings(
            work, inputs["applied"], inputs["armature"], inputs["friction"], stiffness,
            inputs["q"], inputs["dq"], timesteps, inputs["mat"], inputs["pos"],
            inputs["sensordata"], *views, gather)
        out = np.zeros(len(gather))
        bound(first, previous, out)
        gathered.append((work, out))
    (work_c, out_c), (work_r, out_r) = gathered
    assert same_bits(work_c, work_r) and same_bits(out_c, out_r)


@needs_compiled
def test_bad_arrays_are_refused_with_a_clear_error():
    with pytest.raises(TypeError, match="float64"):
        compiled.add_feed_forward(np.zeros(7, np.float32), np.zeros(7), np.zeros(7), np.zeros(7))
    with pytest.raises(ValueError, match="at least 7"):
        compiled.add_feed_forward(np.zeros(6), np.zeros(7), np.zeros(7), np.zeros(7))
    with pytest.raises(TypeError, match="4 arguments"):
        compiled.add_feed_forward(np.zeros(7))
    with pytest.raises(ValueError, match="not C-contiguous"):
        compiled.add_feed_forward(np.zeros(14)[::2], np.zeros(7), np.zeros(7), np.zeros(7))
    with pytest.raises(TypeError, match="bytes-like"):
        compiled.add_feed_forward(np.zeros(7), np.zeros(7), np.zeros(7), [1.0] * 7)


def test_every_kernel_is_listed_and_in_both_modules():
    defined = {name for name, value in vars(reference).items() if inspect.isfunction(value)
               and value.__module__ == reference.__name__ and not name.startswith("_")}
    assert defined - {"signed"} == set(kernels.KERNELS)
    if compiled is not None:
        assert all(callable(getattr(compiled, name, None)) for name in kernels.KERNELS)


def test_a_compiled_module_older_than_the_package_is_not_used():
    """An editable install not reinstalled after a kernel was added: the reference runs."""
    stub = ("import sys, types; sys.modules['franka_sim.kernels._compiled'] = "
            "types.ModuleType('franka_sim.kernels._compiled'); import franka_sim.kernels as k; "
            "print(k.COMPILED); print(k.WHY_NUMPY)")
    env = {k: v for k, v in os.environ.items() if k != "FRANKA_SIM_KERNELS"}
    done = subprocess.run([sys.executable, "-c", stub], capture_output=True, text=True,
                          env=env, timeout=60)
    compiled_flag, why = done.stdout.splitlines()
    assert compiled_flag == "False" and why.startswith("the compiled module predates drive_follow")


def test_the_package_says_which_kernels_it_runs():
    assert kernels.COMPILED is (compiled is not None)
    env = {**os.environ, "FRANKA_SIM_KERNELS": "numpy"}
    done = subprocess.run([sys.executable, "-c", "import franka_sim.kernels as k; "
                           "print(k.COMPILED, k.drive_follow.__module__)"],
                          capture_output=True, text=True, env=env, timeout=60)
    assert done.stdout.split() == ["False", "franka_sim.kernels.reference"]


@pytest.mark.parametrize("pick", ["numpy", ""])
def test_a_server_on_the_numpy_kernels_says_so_at_start(pick):
    """One line, at start, where the cycle runs the reference (a machine without a compiler
    at install time runs it too); none where it runs the compiled module."""
    if not pick and compiled is None:
        pytest.skip("the compiled module is not built here")
    server = ServerProcess(fresh_loopback_address(), env={"FRANKA_SIM_KERNELS": pick})
    server.wait_ready().stop()  # (said before "serving on": read by then)
    said = [line for line in server.lines if "the cycle runs its numpy kernels" in line]
    if pick:
        assert len(said) == 1 and "FRANKA_SIM_KERNELS=numpy" in said[0]
    else:
        assert said == [] and any("serving on" in line for line in server.lines)


@pytest.mark.parametrize("name", ["generate_joint_position_motion", "cartesian_impedance_control",
                                  "grasp_object"])
def test_the_reference_replays_a_recording_identical(name):
    """Recorded on the compiled kernels (or before they existed): the numpy reference gives
    the same states, bit for bit, through a whole client's run."""
    done = replay_committed(RECORDINGS / f"{name}.mcap",
                            env={**os.environ, "FRANKA_SIM_KERNELS": "numpy"})
    assert done.returncode == 0 and done.stdout.startswith("identical"), done.stdout + done.stderr


DESCRIPTIONS = {"franka_sim/urdf/fr3.urdf", "franka_sim/urdf/fer.urdf"}


def _wheel(tmp_path: Path, env: dict) -> tuple[zipfile.ZipFile, str]:
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps",
                           "--no-build-isolation", "-v", "-w", str(tmp_path), str(REPO)],
                          capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    (wheel,) = tmp_path.glob("*.whl")
    return zipfile.ZipFile(wheel), done.stdout + done.stderr


@pytest.mark.skipif(shutil.which("cc") is None, reason="no C compiler on this machine")
def test_pip_builds_the_kernels_where_there_is_a_compiler_and_a_pure_wheel_where_not(tmp_path):
    pytest.importorskip("hatchling", reason="the build backend (the test extra installs it)")
    env = {k: v for k, v in os.environ.items() if k not in ("CC", "FRANKA_SIM_KERNELS")}
    wheel, _ = _wheel(tmp_path / "cc", {**env, "CC": "cc"})
    built = [n for n in wheel.namelist() if n.startswith("franka_sim/kernels/_compiled.")
             and not n.endswith(".c")]
    assert len(built) == 1 and "-cp3" in Path(wheel.filename).name
    assert DESCRIPTIONS <= set(wheel.namelist())
    wheel, log = _wheel(tmp_path / "none", {**env, "CC": str(tmp_path / "no-such-cc")})
    assert Path(wheel.filename).name.endswith("-py3-none-any.whl")
    assert not [n for n in wheel.namelist() if n.endswith((".so", ".pyd"))]
    assert "the compiled kernels are not built (no C compiler" in log
    assert DESCRIPTIONS <= set(wheel.namelist())  # the arms' descriptions go in either way
