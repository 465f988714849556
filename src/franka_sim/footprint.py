"""What the serving process leaves out of memory: libraries a robot server never calls.

Only `franka_sim.serving` (the process that serves `franka-sim serve`) applies these, before it
imports anything else; a program embedding `FrankaSim` keeps its own imports untouched.

- MuJoCo's renderer (OpenGL bindings, glfw, cffi): `import mujoco` goes on without it when
  it is missing, and a server never draws (~3 MiB resident).
- TLS. The FCI speaks plain TCP and UDP, yet asyncio and uvloop import `ssl` at start-up
  and construct imports `hashlib`; both load OpenSSL's libcrypto (~4.5 MiB resident with
  the `ssl` module). hashlib has built-in digests for when OpenSSL is absent, and uvloop
  only reads names off `ssl` while importing: a stand-in module gives it those names, and
  anything that would really use TLS in this process fails with a message saying why. (A
  uvloop the stand-in does not satisfy makes the serving process start again with OpenSSL.)
  aiohttp (the control API) does without `ssl` when it cannot be imported, but would build TLS
  contexts at import from a stand-in: it is imported while `ssl` reads as missing
  (`import_without_tls`).
- MuJoCo's plugins: `import mujoco` loads the plugin libraries it bundles (~0.6 MiB resident)
  and reads every installed package's metadata for plugins others register (`mujoco.plugins`
  entry points; ~13 ms and ~1.8 MiB, importlib.metadata and the parsers it brings). No
  packaged scene uses a plugin: both wait until a scene that is not packaged is loaded
  (`load_plugins`), which then finds them as `import mujoco` would have.
- Modules imported and never used: construct imports `pdb` (for a debugging construct no
  message uses) and `hashlib` (for checksums none has), MuJoCo `zipfile` (for its model
  archives) and `ctypes.util` without calling it. With what they bring (bdb, cmd, code,
  pprint; shutil, bz2, lzma, tempfile, random; the built-in digests) they are ~2.5 MiB
  resident. They still import, and the real module loads on its first use
  (`defer_unused_modules`), a `breakpoint()` included: hashlib's with the control API's
  first request, a recording or a fault plan; the others' with nothing a server does.
"""

from __future__ import annotations

import importlib
import importlib.util
import itertools
import logging
import os
import sys
import threading
import types

log = logging.getLogger(__name__)

_RENDERER_MODULES = ("mujoco._render", "mujoco.rendering", "mujoco.rendering.classic",
                     "mujoco.rendering.classic.renderer", "mujoco.rendering.classic.gl_context")

NO_TLS = "the franka-sim serving process has no TLS (the FCI protocol does not use it)"


def leave_out_renderer() -> None:
    """Make `import mujoco` skip its renderer (an import of it now raises ImportError)."""
    for name in _RENDERER_MODULES:
        sys.modules.setdefault(name, None)


_plugins_deferred = False  # `import mujoco` left its plugins out


def import_mujoco_without_plugins() -> None:
    """Import MuJoCo without loading its plugins (load_plugins does). It skips its scan of the
    entry points when importlib.metadata cannot be imported, and its bundled libraries when
    their folder is not there: both are made to seem so while it imports. (Should MuJoCo find
    its plugins otherwise one day, they load at import as before: nothing breaks.)"""
    global _plugins_deferred
    if "mujoco" in sys.modules or "importlib.metadata" in sys.modules:
        return  # imported already, or the scan would cost nothing more
    spec = importlib.util.find_spec("mujoco")
    if spec is None or not spec.submodule_search_locations:
        return  # (not installed: the import below would say so, where it is made)
    bundled = os.path.join(spec.submodule_search_locations[0], "plugin")
    isdir = os.path.isdir
    sys.modules["importlib.metadata"] = None
    os.path.isdir = lambda path: path != bundled and isdir(path)
    try:
        import mujoco  # noqa: F401
    finally:
        os.path.isdir = isdir
        del sys.modules["importlib.metadata"]
    _plugins_deferred = True


def load_plugins() -> None:
    """Load MuJoCo's plugins as `import mujoco` does (the libraries it bundles, then those
    other packages register), if its import left them out (import_mujoco_without_plugins);
    before a scene that may use one is loaded."""
    global _plugins_deferred
    if not _plugins_deferred:
        return
    _plugins_deferred = False
    import ctypes

    import mujoco

    for folder, _, names in os.walk(mujoco.PLUGINS_DIR):
        for name in sorted(names):
            if os.path.splitext(name)[1] in (".so", ".dylib", ".dll"):
                mujoco.PLUGIN_HANDLES.append(ctypes.CDLL(os.path.join(folder, name)))
    from importlib.metadata import entry_points

    for entry in entry_points(group="mujoco.plugins"):
        try:
            entry.load()()
        except Exception as exc:  # noqa: BLE001 - as MuJoCo does: one broken plugin, a warning
            log.warning("MuJoCo plugin %s not loaded: %s", entry.name, exc)


# Standard modules the core libraries import and a server never uses (module docstring).
DEFERRED = ("pdb", "zipfile", "ctypes.util", "hashlib")


def defer_unused_modules() -> None:
    """Make an import of a DEFERRED module give a stand-in that imports the real module on its
    first use; call before construct and MuJoCo are imported. (importlib's LazyLoader would
    not do: `import` reads a module's `__spec__`, which loads a lazy module at once.) A
    package is not deferred: its submodules' imports need the real one."""
    for name in DEFERRED:
        if name in sys.modules or (spec := importlib.util.find_spec(name)) is None or \
                spec.submodule_search_locations is not None:
            continue
        sys.modules[name] = stand_in = _stand_in(name, spec)
        parent, _, child = name.rpartition(".")
        if parent:  # (`import a.b` then reads a.b off the package)
            setattr(sys.modules[parent], child, stand_in)


_loading = threading.RLock()  # one thread loads a deferred module; the others wait for it


def _stand_in(name: str, spec) -> types.ModuleType:
    def __getattr__(attribute: str):
        if attribute.startswith("__"):
            raise AttributeError(attribute)
        with _loading:
            if sys.modules.get(name) is stand_in:  # the first use: the real one, and the
                del sys.modules[name]  # stand-in (which importers hold) made its copy
                stand_in.__dict__.update(importlib.import_module(name).__dict__)
        return getattr(sys.modules[name], attribute)

    stand_in = types.ModuleType(name, f"{name}, imported on its first use (footprint.py).")
    stand_in.__spec__ = spec
    stand_in.__getattr__ = __getattr__
    return stand_in


def leave_out_tls() -> None:
    """Keep OpenSSL out of this process; call before asyncio, uvloop or construct is imported."""
    if "ssl" in sys.modules or "_hashlib" in sys.modules:
        return  # too late: OpenSSL is loaded already, a stand-in would only hide the real one
    sys.modules["_hashlib"] = None  # hashlib falls back to its built-in digests
    sys.modules["ssl"] = _tls_stand_in()


def import_without_tls(name: str) -> types.ModuleType:
    """Import module `name` as if `ssl` could not be imported, for a package that does without
    TLS then (aiohttp). The stand-in stays what later importers of `ssl` get."""
    stand_in = sys.modules.get("ssl")
    if getattr(stand_in, "__doc__", None) != NO_TLS:  # the real one, or nothing in its place
        return importlib.import_module(name)
    sys.modules["ssl"] = None  # `import ssl` raises ImportError
    try:
        return importlib.import_module(name)
    finally:
        sys.modules["ssl"] = stand_in


class _SSLError(OSError):
    pass


class _Refused:
    """A TLS object (context, memory BIO, default context) that cannot be made here."""

    def __init__(self, *_args, **_kwargs) -> None:
        raise RuntimeError(NO_TLS)


def _tls_stand_in() -> types.ModuleType:
    module = types.ModuleType("ssl", NO_TLS)
    module.SSLError = _SSLError
    module.SSLContext = module.MemoryBIO = module.SSLObject = module.SSLSocket = _Refused
    module.create_default_context = _Refused
    numbers = itertools.count(1000)

    def __getattr__(name: str):
        # What importers read besides the above: error classes (caught, never raised here)
        # and SSL_ERROR_* / PROTOCOL_* numbers (compared, never sent anywhere).
        if name.startswith("__"):
            raise AttributeError(name)
        value = next(numbers) if name.isupper() else type(name, (_SSLError,), {})
        setattr(module, name, value)
        return value

    module.__getattr__ = __getattr__
    return module
