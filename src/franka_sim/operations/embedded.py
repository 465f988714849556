"""The operations as an embedding program calls them: `await sim.push(...)` on a FrankaSim.

`EmbeddedOperations` has one async method per row an arm has (control/table.py), each
handing its arguments to the first arm's operations (the embedder's `control`) and raising
the same refusals the HTTP client does; `ArmOperations` and `BaseOperations` the same for any
robot of a world of several (`sim.operations("right")`, `sim.operations("base")`). Made from
the table, so a new row needs nothing here.
"""

from __future__ import annotations

import inspect

from franka_sim.control.table import OPERATIONS, Kind, Operation


def _signature(operation: Operation) -> inspect.Signature:
    """The implementation's parameters, as the table gives them."""
    parameters = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    for arg in operation.parameters:
        default = inspect.Parameter.empty if arg.required else arg.default
        parameters.append(inspect.Parameter(
            arg.name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=default))
    return inspect.Signature(parameters)


def _callers_signature(operation: Operation) -> inspect.Signature:
    """A row that collects its body's fields into one dict (set_faults) is called as the HTTP
    client calls it: a spec, or its fields as keywords."""
    parameters = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
    parameters += [inspect.Parameter(arg.name, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                     default=None) for arg in operation.arguments]
    return inspect.Signature(parameters)


def _delegate(operation: Operation):
    name, collect = operation.name, operation.collect
    signature = _signature(operation) if collect is None else _callers_signature(operation)

    async def method(self, *args, **kwargs):
        self.check_serving()
        if collect is not None and not (len(args) == 1 and not kwargs
                                        and isinstance(args[0], (dict, list))):
            bound = signature.bind(self, *args, **kwargs)  # TypeError: not the row's fields
            args, kwargs = ({key: value for key, value in bound.arguments.items()
                             if key != "self" and value is not None},), {}
        result = getattr(self.control, name)(*args, **kwargs)
        return await result if inspect.isawaitable(result) else result  # (health: no job)

    method.__name__ = name
    method.__qualname__ = f"EmbeddedOperations.{name}"
    method.__doc__ = operation.doc
    method.__signature__ = signature
    return method


class EmbeddedOperations:
    """Mixed into FrankaSim, whose `control` is its first arm's ArmOps."""

    control = None

    def check_serving(self) -> None:
        """Raise if nothing steps the world now: an operation would wait for ever."""


class RobotOperations:
    """One robot's operations in a world of several (FrankaSim.operations): an arm's, or the
    mobile base's (those its control API serves)."""

    def __init__(self, sim, robot) -> None:
        self._sim, self.control = sim, robot.control

    def check_serving(self) -> None:
        self._sim.check_serving()


class ArmOperations(RobotOperations):
    pass


class BaseOperations(RobotOperations):
    pass


for _operation in OPERATIONS:
    for _kind, _holders in ((Kind.ARM, (EmbeddedOperations, ArmOperations)),
                            (Kind.BASE, (BaseOperations,))):
        if _kind in _operation.kinds:
            for _holder in _holders:
                setattr(_holder, _operation.name, _delegate(_operation))
del _operation, _kind, _holders, _holder
