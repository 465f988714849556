"""The serving process leaves out what a robot server never calls (franka_sim.footprint).

Each check runs in a fresh interpreter: what a process has imported cannot be undone."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import textwrap
from pathlib import Path


# zipfile is a package from Python 3.12 on: not deferred there (footprint.py), it brings
# shutil, bz2 and lzma with it.
ZIPFILE_DEFERRED = importlib.util.find_spec("zipfile").submodule_search_locations is None


def _run(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_without_tls_the_event_loop_serves_udp_and_openssl_is_never_loaded():
    out = _run("""
        from franka_sim.footprint import leave_out_tls
        leave_out_tls()
        import asyncio, hashlib, construct, uvloop

        async def echo_once():
            loop = asyncio.get_running_loop()
            got = loop.create_future()

            class Echo(asyncio.DatagramProtocol):
                def datagram_received(self, data, addr):
                    got.set_result(data)

            transport, _ = await loop.create_datagram_endpoint(
                Echo, local_addr=("127.0.0.1", 0))
            sender, _ = await loop.create_datagram_endpoint(
                asyncio.DatagramProtocol, remote_addr=transport.get_extra_info("sockname"))
            sender.sendto(b"state")
            data = await asyncio.wait_for(got, 10)
            sender.close(); transport.close()
            return data

        assert uvloop.run(echo_once()) == b"state"
        assert hashlib.sha256(b"x").hexdigest().startswith("2d711642")
        maps = open("/proc/self/maps").read()
        print("libcrypto" in maps, "_ssl." in maps, "_hashlib." in maps)
    """)
    assert out.split() == ["False", "False", "False"]


def test_anything_that_would_use_tls_says_why_it_cannot():
    out = _run("""
        from franka_sim.footprint import NO_TLS, leave_out_tls
        leave_out_tls()
        import ssl
        for make in (ssl.create_default_context, ssl.SSLContext, ssl.MemoryBIO):
            try:
                make()
            except RuntimeError as exc:
                assert str(exc) == NO_TLS, exc
            else:
                raise AssertionError(f"{make} made a TLS object")
        assert issubclass(ssl.SSLWantReadError, ssl.SSLError)
        assert ssl.SSL_ERROR_WANT_READ != ssl.SSL_ERROR_WANT_WRITE
        print("refused")
    """)
    assert out.strip() == "refused"


def test_a_process_that_already_loaded_tls_keeps_the_real_one():
    out = _run("""
        import ssl
        from franka_sim.footprint import leave_out_tls
        leave_out_tls()
        import sys
        print(sys.modules["ssl"] is ssl, ssl.create_default_context() is not None)
    """)
    assert out.split() == ["True", "True"]


def test_modules_the_libraries_import_and_a_server_never_uses_load_on_first_use():
    out = _run("""
        import sys
        from franka_sim.footprint import (DEFERRED, defer_unused_modules,
                                          import_mujoco_without_plugins, leave_out_tls)
        defer_unused_modules()
        leave_out_tls()
        import construct, construct.debug
        import_mujoco_without_plugins()
        loaded = lambda names: sorted(name for name in names
                                      if getattr(sys.modules.get(name), "__file__", None))
        kept = () if ZIPFILE_DEFERRED else ("zipfile", "bz2", "lzma", "shutil")
        print(sorted(set(loaded((*DEFERRED, "bdb", "bz2", "lzma", "shutil", "tempfile",
                                 "random"))) - set(kept)))
        import ctypes.util, hashlib, io, zipfile
        archive = io.BytesIO()
        with zipfile.ZipFile(archive, "w") as writing:
            writing.writestr("a.txt", "b")
        print(zipfile.is_zipfile(archive), ctypes.util.find_library("c") is not None,
              hashlib.sha256(b"x").hexdigest()[:8], construct.debug.pdb.Pdb.__module__)
        import pdb
        print(pdb.set_trace.__module__, loaded(DEFERRED) == sorted(DEFERRED))
    """.replace("ZIPFILE_DEFERRED", str(ZIPFILE_DEFERRED)))
    assert out.split("\n")[:3] == ["[]", "True True 2d711642 pdb", "pdb True"]


def test_a_uvloop_the_stand_in_does_not_satisfy_gets_the_real_tls(tmp_path):
    """A future uvloop might read something off `ssl` the stand-in lacks: the serving process
    then starts again with OpenSSL (one warning) instead of failing to serve."""
    import pylibfranka
    from franka_sim.testing import running_sim

    fake = tmp_path / "uvloop"
    fake.mkdir()
    (fake / "__init__.py").write_text(
        "import asyncio, ssl\n"
        "ssl.OPENSSL_VERSION.split()  # a string on the real module\n"
        "run = asyncio.run\n")
    env = {"PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    with running_sim(env=env) as sim:
        assert len(sim.log_matching("uvloop does not import without OpenSSL")) == 1
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        del robot
        assert "libcrypto" in Path(f"/proc/{sim.proc.pid}/maps").read_text()


def test_aiohttp_is_imported_as_without_tls_and_the_stand_in_stays():
    out = _run("""
        from franka_sim.footprint import NO_TLS, import_without_tls, leave_out_tls
        leave_out_tls()
        import uvloop
        import_without_tls("aiohttp.web")
        import ssl, aiohttp.connector
        maps = open("/proc/self/maps").read()
        print(ssl.__doc__ == NO_TLS, aiohttp.connector.ssl is None, "libcrypto" in maps)
    """)
    assert out.split() == ["True", "True", "False"]


def test_the_serving_process_answers_its_control_api_without_openssl():
    from franka_sim.control import Control
    from franka_sim.testing import running_sim

    with running_sim() as sim:
        assert Control(sim.host).state()["robot_mode"] == "Idle"
        maps = Path(f"/proc/{sim.pid}/maps").read_text()
    assert "libcrypto" not in maps and "_ssl." not in maps and "_hashlib." not in maps


def test_the_control_api_costs_nothing_until_its_first_connection():
    """Its port is held from the start; aiohttp is loaded when somebody connects to it."""
    import pylibfranka

    from franka_sim.control import Control
    from franka_sim.testing import running_sim

    def aiohttp_loaded(pid: int) -> bool:
        return "aiohttp" in Path(f"/proc/{pid}/maps").read_text()  # its compiled parsers

    with running_sim() as sim:
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        assert not aiohttp_loaded(sim.pid)
        assert Control(sim.host).state()["robot_mode"] == "Idle"
        assert aiohttp_loaded(sim.pid)
        del robot


def test_mujoco_plugins_other_packages_register_load_with_a_scene_that_is_not_packaged(tmp_path):
    """The serving process imports MuJoCo without its plugins: neither the libraries it bundles
    nor its scan of every package's entry points. A scene from a file loads both before it is
    loaded (once); a packaged one does not need them."""
    info = tmp_path / "site" / "fakeplugin-1.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fakeplugin\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[mujoco.plugins]\nfake = fakeplugin:register\n")
    (tmp_path / "site" / "fakeplugin.py").write_text(
        "CALLS = []\ndef register():\n    CALLS.append(1)\n")
    scene = tmp_path / "my_scene.xml"
    from franka_sim.physics.scene import default_scene_path

    scene.write_text(default_scene_path().read_text())
    out = _run(f"""
        import sys
        sys.path.insert(0, {str(tmp_path / "site")!r})
        from franka_sim.footprint import import_mujoco_without_plugins
        import_mujoco_without_plugins()
        import mujoco, fakeplugin
        print("metadata" if "importlib.metadata" in sys.modules else "no metadata",
              len(mujoco.PLUGIN_HANDLES) > 0, len(fakeplugin.CALLS))
        from franka_sim.config import Config
        from franka_sim.server.sim import FrankaSim
        FrankaSim(Config(host="127.0.0.1"))
        print(len(fakeplugin.CALLS), len(mujoco.PLUGIN_HANDLES))
        FrankaSim(Config(host="127.0.0.1", scene={str(scene)!r}))
        bundled = len(mujoco.PLUGIN_HANDLES)
        FrankaSim(Config(host="127.0.0.1", scene={str(scene)!r}))
        print(len(fakeplugin.CALLS), bundled, len(mujoco.PLUGIN_HANDLES))
    """)
    import mujoco

    bundled = len(list((Path(mujoco.__file__).parent / "plugin").glob("*.so")))
    assert bundled > 0
    assert out.split("\n")[:3] == ["no metadata False 0", "0 0", f"1 {bundled} {bundled}"]
    plain = _run(f"""
        import sys
        sys.path.insert(0, {str(tmp_path / "site")!r})
        import mujoco, fakeplugin
        print(len(fakeplugin.CALLS), len(mujoco.PLUGIN_HANDLES))
    """)
    assert plain.strip() == f"1 {bundled}"  # what `import mujoco` alone does, for comparison


# What a server loads only when it meets what needs it: an older client (its protocol module,
# its model library's compiler plumbing), a fault spec, a vacuum gripper, jitter's statistics
# (with fractions and decimal). (The IDNA codec a host that is not ASCII needs: below, as this
# test's own Python client would load it.)
ON_FIRST_USE = ("franka_sim.protocol.robot_v9", "franka_sim.protocol.robot_v5",
                "franka_sim.model_library", "franka_sim.faults.plan", "franka_sim.faults.link",
                "franka_sim.faults.spec", "franka_sim.robot.vacuum_gripper",
                "franka_sim.physics.suction", "statistics", "decimal",
                "xml.etree.ElementTree")  # (the URDF is read with expat: description/xml_tree.py)


def test_a_server_serving_a_v10_client_and_its_hand_loads_nothing_it_did_not_meet():
    from franka_sim.testing import fresh_loopback_address

    host = fresh_loopback_address()
    out = _run(f"""
        import asyncio, sys
        from franka_sim.config import Config
        from franka_sim.server.sim import FrankaSim
        from franka_sim.testing import RawClient

        async def main():
            async with FrankaSim(Config(host={host!r})) as sim:
                def client():
                    robot = RawClient({host!r})
                    robot.recv()
                    robot.close()
                await asyncio.to_thread(client)
                print("franka_sim.operations.arm" in sys.modules)  # (nobody called them yet)
                print((await sim.state())["robot_mode"], sim.tool is not None)

        asyncio.run(main())
        print(sorted(name for name in {ON_FIRST_USE!r} if name in sys.modules))
    """)
    assert out.split("\n")[:3] == ["False", "Idle True", "[]"]


def test_the_serving_process_keeps_the_libraries_behind_them_unmapped():
    """The same seen from outside, in the serving process under pylibfranka with a Gripper:
    the compiled modules that statistics, the IDNA codec and the deferred modules bring
    (franka_sim.footprint), and MuJoCo's own plugins."""
    import pylibfranka
    from franka_sim.testing import running_sim

    with running_sim() as sim:
        robot = pylibfranka.Robot(sim.host, pylibfranka.RealtimeConfig.kIgnore)
        gripper = pylibfranka.Gripper(sim.host)
        assert robot.read_once().robot_mode == pylibfranka.RobotMode.Idle
        assert gripper.read_once().max_width > 0.07
        maps = Path(f"/proc/{sim.pid}/maps").read_text()
        del robot, gripper
    behind_zipfile = ("_bz2.", "_lzma.") if ZIPFILE_DEFERRED else ()
    for library in ("_decimal.", "unicodedata.", *behind_zipfile, "_random.", "_sha512.",
                    "libsensor.so", "libactuator.so", "libsdf_plugin.so", "libmujoco"):
        assert (library in maps) == (library == "libmujoco"), library
