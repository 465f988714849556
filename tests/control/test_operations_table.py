"""The table of operations is the one list: the HTTP routes, the Python client's methods,
FrankaSim's methods and each robot's implementation all have exactly its rows, with its
arguments; the docs list them too. No server: the classes and the aiohttp app are read."""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from franka_sim import FrankaSim
from franka_sim.control import Control
from franka_sim.operations.arm import ArmOps
from franka_sim.operations.base import BaseOps
from franka_sim.control.table import BY_NAME, OPERATIONS, Effect, Kind, served_by
from franka_sim.server.control_api import ControlApi, route_path
from franka_sim.faults.spec import KEYS as FAULT_KEYS

DOCS = Path(__file__).resolve().parents[2] / "docs" / "control_api.md"
IMPLEMENTATIONS = {Kind.ARM: ArmOps, Kind.BASE: BaseOps}
ROWS = pytest.mark.parametrize("operation", OPERATIONS, ids=[op.name for op in OPERATIONS])


def parameters(function) -> list[tuple[str, object]]:
    """(name, default; `empty` when required) of each parameter after self."""
    return [(p.name, p.default) for p in
            list(inspect.signature(function).parameters.values())[1:]]


def expected(args) -> list[tuple[str, object]]:
    return [(arg.name, inspect.Parameter.empty if arg.required else arg.default)
            for arg in args]


def public_methods(cls) -> set[str]:
    return {name for name, value in inspect.getmembers(cls, callable)
            if not name.startswith("_")}


def test_the_rows_are_distinct_and_well_formed():
    assert len(BY_NAME) == len(OPERATIONS)
    routes = [(op.method, op.path) for op in OPERATIONS]
    assert len(set(routes)) == len(routes)
    for op in OPERATIONS:
        assert op.method in {"GET", "POST", "PUT", "DELETE"} and op.path.startswith("/")
        assert op.kinds
        assert op.method != "GET" or not op.body  # a GET has no body
        assert op.effect is not Effect.CHANGE or op.method != "GET"
        assert not set(op.path_args) & {arg.name for arg in op.body}


def test_post_faults_takes_exactly_the_fault_specs_fields():
    assert tuple(BY_NAME["set_faults"].fields) == ("spec", *FAULT_KEYS, "seed")


@pytest.mark.parametrize("kind", list(Kind))
def test_each_kind_implements_exactly_its_rows_with_the_rows_parameters(kind):
    implementation = IMPLEMENTATIONS[kind]
    assert public_methods(implementation) == {op.name for op in served_by(kind)}
    for op in served_by(kind):
        assert parameters(getattr(implementation, op.name)) == expected(op.parameters), op.name


def test_the_client_has_a_method_per_row_with_the_rows_arguments():
    assert public_methods(Control) == set(BY_NAME)
    for op in OPERATIONS:
        method = getattr(Control, op.name)
        assert parameters(method) == expected(op.arguments), op.name
        assert method.__doc__ == op.doc


def test_frankasim_has_an_async_method_per_arm_row_with_the_implementations_parameters():
    """(A row collecting its fields into one dict takes them as the HTTP client does.)"""
    for op in served_by(Kind.ARM):
        method = getattr(FrankaSim, op.name)
        assert inspect.iscoroutinefunction(method), op.name
        like = ArmOps if op.collect is None else Control
        assert parameters(method) == parameters(getattr(like, op.name)), op.name


@ROWS
def test_the_client_sends_the_rows_request(operation):
    """Each method's request: the row's method, its path with the path's arguments put in, a
    body of the body's arguments given (None: left out) when the row takes one."""
    sent = []
    control = Control("127.0.0.1")
    control._call = lambda method, path, body=None: sent.append((method, path, body)) or {
        operation.answer_key: "answer"}
    given = {arg.name: f"value of {arg.name}" for arg in operation.arguments if arg.required}
    answer = getattr(control, operation.name)(**given)
    method, path, body = sent[0]
    assert (method, path) == (operation.method,
                              operation.where(**{n: f"value%20of%20{n}"
                                                 for n in operation.path_args}))
    if not operation.body:
        assert body is None
    else:
        defaults = {a.name: a.default for a in operation.body if a.default is not None}
        assert body == {**defaults, **{n: v for n, v in given.items() if n in operation.fields}}
    if operation.answer_key is not None:
        assert answer == "answer"


@pytest.mark.parametrize("kind", list(Kind))
def test_the_routes_are_the_rows_on_every_robot(kind):
    """Every row is routed on every robot (a row its kind lacks: to a 404 saying so)."""
    ops = SimpleNamespace(**dict.fromkeys(BY_NAME), kind=kind)
    routes = {(route.method, route.resource.canonical)  # (canonical: the path as the row's)
              for route in ControlApi(ops).app.router.routes() if route.method != "HEAD"}
    assert routes == {(op.method, op.path) for op in OPERATIONS}
    assert route_path(BY_NAME["pose"]) == "/bodies/{name:.+}"  # a name may hold a /


def test_the_docs_list_every_row_and_the_bases():
    text = DOCS.read_text()
    listed = set(re.findall(r"^\| `(GET|POST|PUT|DELETE) (/[^`]*)` \|", text, re.MULTILINE))
    assert listed == {(op.method, op.path) for op in OPERATIONS}
    base = text[text.index("## The mobile base"):]
    said = set(re.findall(r"`(GET|POST|PUT|DELETE) (/[^`]*)`", base.split("\n## ")[0]))
    assert {(op.method, op.path) for op in served_by(Kind.BASE)} <= said


def test_the_client_and_its_table_need_the_standard_library_only():
    done = subprocess.run([sys.executable, "-c", (
        "import sys; from franka_sim.control import Control; "
        "print(sorted({m.split('.')[0] for m in sys.modules} & {'numpy', 'aiohttp', 'mujoco'}))")],
        capture_output=True, text=True, timeout=60, check=True)
    assert done.stdout.split() == ["[]"]
