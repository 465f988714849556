"""Where a model library comes from (model_library/build.py): prebuilt ones first
($FRANKA_SIM_MODEL_LIBRARIES), then the cache, then the compiler; another machine's served
when one is prebuilt for it, else kError in one log line; `python -m franka_sim.model_library`
makes the prebuilt directory. Fake libraries in temporary directories (no compiler needed),
and where the ziglang package is installed, a real aarch64 library cross-compiled."""

from __future__ import annotations

import ctypes
import logging
import shutil
import sys

import numpy as np
import pytest
from construct import Container

from franka_sim.description.kinematics import flange_pose
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.model_library import ModelLibrary
from franka_sim.model_library import __main__ as prebuild_cli
from franka_sim.model_library.build import (PREBUILT_VARIABLE, cache_dir, library_name,
                                            system_compiler, this_machine, zig_compiler)
from franka_sim.model_library.source import c_source
from support.elf import elf_machine

X64, ARM64 = ("kX64", "kLinux"), ("kARM64", "kLinux")
OTHER = ARM64 if this_machine() != ARM64 else X64  # a machine other than this one


def _request(target):
    return Container(architecture=target[0], system=target[1])


@pytest.fixture(scope="module")
def description():
    return load_arm_description(default_urdf_text("fr3"))


@pytest.fixture
def places(tmp_path, monkeypatch):
    """An empty prebuilt directory and cache, and a compiler that fails if it is run."""
    prebuilt = tmp_path / "prebuilt"
    prebuilt.mkdir()
    monkeypatch.setenv(PREBUILT_VARIABLE, str(prebuilt))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    return prebuilt, cache_dir()


def _put(directory, description, target, data: bytes):
    directory.mkdir(parents=True, exist_ok=True)
    (directory / library_name(c_source(description), target)).write_bytes(data)


def test_a_prebuilt_library_comes_before_the_cache_and_the_compiler(description, places):
    prebuilt, cache = places
    _put(prebuilt, description, this_machine(), b"\x7fELF prebuilt")
    _put(cache, description, this_machine(), b"\x7fELF kept")
    assert ModelLibrary(description).for_client(_request(this_machine())) == b"\x7fELF prebuilt"


def test_the_cache_comes_before_the_compiler(description, places):
    _, cache = places
    _put(cache, description, this_machine(), b"\x7fELF kept")
    assert ModelLibrary(description).for_client(_request(this_machine())) == b"\x7fELF kept"


def test_another_machines_library_is_served_when_one_is_prebuilt(description, places,
                                                                  monkeypatch):
    prebuilt, _ = places
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    _put(prebuilt, description, OTHER, b"\x7fELF other")
    library = ModelLibrary(description)
    assert library.for_client(_request(OTHER)) == b"\x7fELF other"
    assert library.for_client(_request(("kX64", "kWindows"))) is None  # none prebuilt


def test_a_library_is_found_by_its_descriptions_source(description, places, monkeypatch):
    """The Panda's prebuilt library is not the FR3's: a description whose source differs
    (e.g. a custom --urdf) finds none."""
    prebuilt, _ = places
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    _put(prebuilt, load_arm_description(default_urdf_text("fer")), OTHER, b"\x7fELF fer")
    assert ModelLibrary(description).for_client(_request(OTHER)) is None


def test_another_machine_without_one_is_k_error_in_one_log_line(description, places,
                                                                monkeypatch, caplog):
    prebuilt, _ = places
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    with caplog.at_level(logging.INFO, logger="franka_sim.model_library"):
        assert ModelLibrary(description).for_client(_request(OTHER)) is None
    (line,) = [r.getMessage() for r in caplog.records]  # one line a request
    assert line.startswith(f"model library for {OTHER[0]}/{OTHER[1]} asked for: none "
                           f"prebuilt (in {prebuilt})"), line
    assert line.endswith("answered kError"), line


def test_a_library_prebuilt_after_a_miss_is_served(description, places, monkeypatch):
    """A miss is not remembered: a library put in place while the server runs is found."""
    prebuilt, _ = places
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    library = ModelLibrary(description)
    assert library.for_client(_request(OTHER)) is None
    _put(prebuilt, description, OTHER, b"\x7fELF other")
    assert library.for_client(_request(OTHER)) == b"\x7fELF other"


def test_a_prebuilt_variable_naming_no_directory_is_said(description, tmp_path, monkeypatch,
                                                         caplog):
    monkeypatch.setenv(PREBUILT_VARIABLE, str(tmp_path / "missing"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    with caplog.at_level(logging.WARNING, logger="franka_sim.model_library"):
        assert ModelLibrary(description).for_client(_request(OTHER)) is None
        assert ModelLibrary(description).for_client(_request(OTHER)) is None
    said = f"{PREBUILT_VARIABLE}={tmp_path / 'missing'} is no directory"
    assert caplog.text.count(said) == 1  # once a process


def test_a_target_libfranka_has_no_name_for_is_k_error(description, places, caplog):
    with caplog.at_level(logging.WARNING, logger="franka_sim.model_library"):
        assert ModelLibrary(description).for_client(_request(("7", "kLinux"))) is None
    assert "7/kLinux asked for: no such target: answered kError" in caplog.text


def test_a_cc_naming_no_compiler_is_passed_over_for_the_machines_own(monkeypatch):
    """$CC names nothing that is there: this machine's cc is used (or none, then zig may be),
    not a command that fails at the first build."""
    monkeypatch.setenv("CC", "/no/such/cc -O2")
    found = system_compiler()
    assert found is None or (found[0] != "/no/such/cc" and shutil.which(found[0]))
    monkeypatch.setenv("CC", f"{sys.executable} -c pass")
    assert system_compiler() == [sys.executable, "-c", "pass"]


def test_the_prebuild_command_refuses_what_it_cannot_build(tmp_path, capsys):
    cc = "cc-that-is-not-zig"
    assert prebuild_cli.main([str(tmp_path), "--cc", cc, "--target", "aarch64-linux"
                              if this_machine() != ARM64 else "x86_64-linux"]) == 1
    assert "builds no library for" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exited:
        prebuild_cli.main([str(tmp_path), "--target", "sparc-linux"])
    assert exited.value.code == 2
    assert "no such target 'sparc-linux'" in capsys.readouterr().err
    assert prebuild_cli.main([str(tmp_path), "--urdf", str(tmp_path / "none.urdf")]) == 1
    assert "none.urdf" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.so"))


needs_zig = pytest.mark.skipif(
    zig_compiler() is None,
    reason="the ziglang package is not installed (the test extra has it): no cross-compiler")


@needs_zig
def test_zig_builds_the_prebuilt_directory_that_serves_an_aarch64_client(description, tmp_path,
                                                                         monkeypatch, capsys):
    """`python -m franka_sim.model_library DIR` with ziglang: both Linux targets; the server
    then answers an aarch64 client with an aarch64 ELF shared object."""
    out = tmp_path / "prebuilt"
    assert prebuild_cli.main([str(out), "--robot", "fr3", "--cc",
                              f"{sys.executable} -m ziglang cc"]) == 0
    assert len(capsys.readouterr().out.splitlines()) == 2
    monkeypatch.setenv(PREBUILT_VARIABLE, str(out))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr("franka_sim.model_library.build.zig_compiler", lambda: None)
    library = ModelLibrary(description)
    assert elf_machine(library.for_client(_request(ARM64))) == "aarch64"
    assert elf_machine(library.for_client(_request(X64))) == "x86_64"
    assert not cache_dir().exists()  # nothing built: both prebuilt
    if this_machine() in (X64, ARM64):  # this machine's loads: the description's flange pose
        path = tmp_path / "here.so"
        path.write_bytes(library.for_client(_request(this_machine())))
        doubles = ctypes.POINTER(ctypes.c_double)
        q, pose = np.linspace(-1.0, 1.0, 7), np.zeros(16)
        ctypes.CDLL(str(path)).O_T_J8(q.ctypes.data_as(doubles), pose.ctypes.data_as(doubles))
        assert np.allclose(pose.reshape(4, 4).T, flange_pose(description, q), atol=1e-14)


@needs_zig
def test_without_a_c_compiler_zig_builds_for_the_machine_asked_for(description, tmp_path,
                                                                   monkeypatch):
    """Outside an image, no `cc` but ziglang installed: `python -m ziglang cc` builds the
    library, for another Linux machine too, and keeps it."""
    monkeypatch.delenv(PREBUILT_VARIABLE, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("PATH", str(tmp_path))  # no cc, no gcc
    monkeypatch.delenv("CC", raising=False)
    data = ModelLibrary(description).for_client(_request(ARM64))
    assert elf_machine(data) == "aarch64"
    kept = cache_dir() / library_name(c_source(description), ARM64)
    assert kept.read_bytes() == data
