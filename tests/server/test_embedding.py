"""FrankaSim embedded in an existing asyncio application (plain asyncio, no uvloop)."""

from __future__ import annotations

import asyncio
import re
import subprocess
import sys
import textwrap

import pytest

from franka_sim import FrankaSim
from franka_sim.config import ArmSpec
from franka_sim.config_rules import ConfigError
from franka_sim.testing import fresh_loopback_address

CLIENT = textwrap.dedent("""
    import sys, pylibfranka
    robot = pylibfranka.Robot(sys.argv[1], pylibfranka.RealtimeConfig.kIgnore)
    state = robot.read_once()
    print(state.robot_mode.name, round(state.m_ee, 3))
""")


def test_async_with_serves_a_real_client_and_shuts_down_cleanly():
    host = fresh_loopback_address()

    async def app():
        assert "uvloop" not in type(asyncio.get_running_loop()).__module__
        async with FrankaSim(host=host) as sim:
            assert sim.address == (host, 1337)
            # pylibfranka blocks and holds the GIL, so the client runs in its own process.
            proc = await asyncio.create_subprocess_exec(
                sys.executable, "-c", CLIENT, host, stdout=asyncio.subprocess.PIPE)
            out, _ = await asyncio.wait_for(proc.communicate(), 60)
            ticks = sim.core.message_id
        return out.decode(), ticks, asyncio.all_tasks()

    out, ticks, tasks = asyncio.run(app())
    assert out.split() == ["Idle", "0.73"]
    assert ticks > 0
    assert len(tasks) == 1  # only app() itself: the simulator left nothing running
    # The address is free again at once.
    again = subprocess.run(
        [sys.executable, "-c", f"import socket; s=socket.socket(); s.bind(('{host}', 1337))"])
    assert again.returncode == 0


def test_several_simulators_in_one_process_name_their_lines():
    """Each simulator's lines start with its address while another serves in the process
    (log_names.py); alone, its lines name none, as `serve`'s do."""
    import logging

    from franka_sim.log_names import RobotName

    first, second = fresh_loopback_address(), fresh_loopback_address()
    lines: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda record: lines.append(f"{record.robot}{record.getMessage()}")
    handler.addFilter(RobotName())
    logger = logging.getLogger("franka_sim")
    logger.addHandler(handler)

    async def read_from(host: str) -> str:
        proc = await asyncio.create_subprocess_exec(
            sys.executable, "-c", CLIENT, host, stdout=asyncio.subprocess.PIPE)
        out, _ = await asyncio.wait_for(proc.communicate(), 60)
        return out.decode()

    async def app():
        async with FrankaSim(host=first):
            await read_from(first)
            async with FrankaSim(host=second, clock="lockstep"):
                outs = await asyncio.gather(read_from(first), read_from(second))
            await read_from(first)
            return outs

    level = logger.level
    logger.setLevel(logging.INFO)  # (setLevel: the loggers' cached levels are cleared too)
    try:
        outs = asyncio.run(app())
    finally:
        logger.setLevel(level)
        logger.removeHandler(handler)
    assert [out.split()[0] for out in outs] == ["Idle", "Idle"]
    connected = [line for line in lines if "client" in line and " connected" in line]
    assert len(connected) == 4, lines
    alone, *together, alone_again = connected
    assert alone.startswith("FCI client ") and alone_again.startswith("FCI client ")
    assert sorted(line.split(": ")[0] for line in together) == sorted([first, second])
    assert any(line.startswith(f"{second}: simulated FR3") for line in lines), lines


def test_each_robot_of_a_world_of_several_has_its_operations():
    left, right, base = (fresh_loopback_address() for _ in range(3))

    async def app():
        async with FrankaSim(scene="mobile_duo", mobile_base=base,
                             arms=(ArmSpec("left", left), ArmSpec("right", right))) as sim:
            proc = await asyncio.create_subprocess_exec(
                sys.executable, "-c", CLIENT, right, stdout=asyncio.subprocess.PIPE)
            out, _ = await asyncio.wait_for(proc.communicate(), 60)
            arm = sim.operations("right")
            health, state = await arm.health(), await arm.state()
            await arm.reset()
            base_health = await sim.operations("base").health()
            with pytest.raises(KeyError, match=r"no robot named 'nope' \(left, right, base\)"):
                sim.operations("nope")
            assert not hasattr(sim.operations("base"), "reset")  # (its API serves none)
        with pytest.raises(RuntimeError, match="not serving"):
            await arm.state()
        return out.decode(), health, state, base_health

    out, health, state, base_health = asyncio.run(app())
    assert out.split()[0] == "Idle"
    assert health["arm"] == "right"
    assert state["robot_mode"] == "Idle" and base_health["mobile_base"] is True


def test_the_clock_by_its_name_and_a_misspelt_setting():
    host = fresh_loopback_address()
    with pytest.raises(TypeError, match="no setting 'clok'"):
        FrankaSim(host=host, clok="lockstep")
    with pytest.raises(ConfigError, match="'lockstop' is not a clock"):
        FrankaSim(host=host, clock="lockstop")

    async def app():
        async with FrankaSim(host=host, clock="lockstep") as sim:
            return (await sim.health())["clock"]

    assert asyncio.run(app()) == "lockstep"


@pytest.mark.parametrize("settings, said", [
    ({"enforce_motion_limits": "no"}, "'no' is not True or False"),  # (a string is true)
    ({"control_port": -5}, "-5 is not a TCP port"),
    ({"seed": -1}, "-1 is not a non-negative integer"),
    ({"desk_boot": "locked"}, "brought up through its Desk: give --desk-port"),
    ({"arms": (ArmSpec("left", "127.0.0.2", (0.0, 0.0)),)}, "its base (0.0, 0.0) is x, y, z"),
    # what only an embedder can give
    ({"robot_port": 70000}, "70000 is not a TCP port"),
    ({"robot_port": 0}, "0 is not a TCP port"),
    ({"robot_port": "1337"}, "'1337' is not a TCP port"),
    ({"robot_port": 1340}, "1340 is another service's port"),
    ({"tool_port": "1338"}, "'1338' is not a TCP port"),
    ({"q0": (float("nan"),) * 7}, "is not 7 finite joint angles"),
    ({"q0": (0.0,) * 6}, "is not 7 finite joint angles"),
    ({"q0": "ready"}, "'ready' is not 7 joint angles"),
    ({"arms": (("left", "127.0.0.2"),)}, "('left', '127.0.0.2') is not an ArmSpec"),
])
def test_settings_serve_refuses_are_refused_by_name_in_embedding_too(settings, said):
    with pytest.raises(ConfigError, match=re.escape(said)):
        FrankaSim(host=fresh_loopback_address(), **settings)


def test_a_start_pose_past_a_joint_limit_is_refused_and_paths_may_be_strings(tmp_path):
    from franka_sim.config import READY_POSE
    from franka_sim.description.urdf import default_urdf_text
    from franka_sim.physics.scene import SceneError

    with pytest.raises(SceneError, match=r"its start pose q0 \[3.0, .* is outside its joint "
                                         r"limits"):
        FrankaSim(host=fresh_loopback_address(), q0=(3.0, *READY_POSE[1:]))
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(default_urdf_text())
    sim = FrankaSim(host=fresh_loopback_address(), urdf=str(urdf))
    assert sim.urdf_text == urdf.read_text()


def test_an_arm_that_would_start_inside_a_body_is_refused_and_leaves_no_thread(tmp_path):
    import threading

    from franka_sim.physics.scene import SceneError

    scene = tmp_path / "slab.xml"  # a box where the Hand is at the ready pose
    scene.write_text("<mujoco><worldbody><body name='slab' pos='0.31 0 0.5'><geom type='box' "
                     "size='0.04 0.04 0.04'/></body></worldbody></mujoco>")

    async def app():
        async with FrankaSim(host=fresh_loopback_address(), scene=str(scene), control_port=0):
            pass

    with pytest.raises(SceneError, match="hand into scene/slab"):
        asyncio.run(app())
    assert not [t for t in threading.enumerate() if t.name == "franka-sim-cycle"]


def test_a_stopped_simulator_says_so_instead_of_waiting():
    host = fresh_loopback_address()

    async def app():
        sim = FrankaSim(host=host)
        with pytest.raises(RuntimeError, match="not serving"):
            await sim.state()  # before it starts
        async with sim:
            assert (await sim.state())["robot_mode"] == "Idle"
        with pytest.raises(RuntimeError, match="not serving"):
            await sim.state()
        with pytest.raises(RuntimeError, match="serves once"):
            await sim.start()

    asyncio.run(asyncio.wait_for(app(), 60))


def test_a_stop_ends_the_robots_before_it_waits_for_the_web_view():
    """The web view's stop may wait on its open page; meanwhile no robot is served (a client
    connected after "stopping" and ran a whole motion while a page was open)."""
    import socket

    host = fresh_loopback_address()
    seen = []

    class SlowWebView:  # (what FrankaSim.stop asks of web/live.py's LiveView)
        def stop(self):
            for port in (1337, 1338, 1340):
                try:
                    socket.create_connection((host, port), timeout=2).close()
                    seen.append((port, "served"))
                except ConnectionRefusedError:
                    seen.append((port, "refused"))

    async def app():
        sim = await FrankaSim(host=host).start()
        sim.web = SlowWebView()
        await sim.stop()

    asyncio.run(app())
    assert seen == [(1337, "refused"), (1338, "refused"), (1340, "refused")]


def _left_running() -> list[str]:
    import threading

    return [t.name for t in threading.enumerate()
            if t.name in ("franka-sim-cycle", "fsim-recorder", "fsim-web")]


def _bindable(host: str, port: int) -> bool:
    import socket

    with socket.socket() as probe:
        try:
            probe.bind((host, port))
        except OSError:
            return False
    return True


def test_a_config_given_to_several_simulators_stays_the_callers():
    from franka_sim.config import ClockMode, Config

    base = Config(control_port=0)
    first, second = fresh_loopback_address(), fresh_loopback_address()
    a = FrankaSim(base, host=first)
    b = FrankaSim(base, host=second, clock="lockstep")
    assert (base.host, base.clock) == (Config().host, ClockMode.realtime)
    assert (a.config.host, b.config.host) == (first, second)

    async def app():
        async with a, b:
            return (await a.health())["clock"], (await b.health())["clock"]

    assert asyncio.run(app()) == ("realtime", "lockstep")


def test_a_start_cancelled_while_the_web_view_starts_leaves_nothing_serving(monkeypatch):
    """The thread starting viser goes on after the cancel: the stop waits for it and stops it,
    and the next simulator has the address and the web port."""
    pytest.importorskip("viser", reason="the web view needs franka-sim[web] (viser)")
    import threading

    from franka_sim.web.live import LiveView

    host, web_port = fresh_loopback_address(), 8181
    starting, go_on = threading.Event(), threading.Event()
    real_start = LiveView.start

    def held_start(view):
        starting.set()
        go_on.wait(30)
        real_start(view)

    monkeypatch.setattr(LiveView, "start", held_start)

    async def app():
        sim = FrankaSim(host=host, control_port=0, web_port=web_port)
        task = asyncio.create_task(sim.start())
        while not starting.is_set():
            await asyncio.sleep(0.01)
        task.cancel()
        go_on.set()
        with pytest.raises(asyncio.CancelledError):
            await task
        assert not _left_running() and _bindable(host, web_port) and _bindable(host, 1337)
        monkeypatch.setattr(LiveView, "start", real_start)
        async with FrankaSim(host=host, control_port=0, web_port=web_port) as again:
            return again.web.port

    assert asyncio.run(asyncio.wait_for(app(), 120)) == web_port


def test_a_stop_cancelled_twice_ends_all_the_same(tmp_path):
    """A task leaving `async with` is cancelled again while it stops (a task group's cancel,
    then a timeout's): the stop runs to its end, a later stop() waits for it, and the
    recording is whole."""
    from franka_sim.recording.reader import open_recording

    host, path = fresh_loopback_address(), tmp_path / "run.mcap"

    async def app():
        sim = FrankaSim(host=host, control_port=0, record=str(path), clock="lockstep")

        async def serve():
            async with sim:
                await asyncio.sleep(100)

        task = asyncio.create_task(serve())
        while not sim.core.message_id:
            await asyncio.sleep(0.01)
        task.cancel()
        await asyncio.sleep(0)
        task.cancel()
        with pytest.raises(asyncio.CancelledError):
            await task
        await sim.stop()
        return _left_running(), _bindable(host, 1337)

    pytest.importorskip("mcap", reason="recording needs franka-sim[record]")
    assert asyncio.run(asyncio.wait_for(app(), 60)) == ([], True)
    assert open_recording(path).metadata
