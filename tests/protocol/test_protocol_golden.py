"""Every golden vector in protocol_specs/golden/ is built and parsed exactly by our structs.

The vectors come from protocol_specs/make_golden.py, which places values with the standard
struct module at the documented offsets, independently of franka_sim.
"""

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

import franka_sim.protocol as protocol
import franka_sim.protocol.robot_v5  # noqa: F401 - their vectors name them protocol.robot_v5 …
import franka_sim.protocol.robot_v6  # noqa: F401
import franka_sim.protocol.robot_v9  # noqa: F401
from franka_sim.protocol import (
    ControllerMode,
    GripperStateBuffer,
    MotionGeneratorMode,
    RobotMode,
    StateBuffer,
    decode_command,
    decode_gripper_state,
    decode_state,
    encode_command,
)

SPECS = Path(__file__).resolve().parents[2] / "protocol_specs"
GOLDEN_FILES = sorted((SPECS / "golden").glob("*.json"))


def load(path):
    doc = json.loads(path.read_text())
    for key in doc.get("text_fields", []):
        doc["fields"][key] = doc["fields"][key].encode()
    return doc


def assert_matches(parsed, expected, path="fields"):
    """Compare a parsed Container with golden values (enum fields compare by FCI name)."""
    if isinstance(expected, dict):
        assert {k for k in parsed if not k.startswith("_")} == set(expected), path
        for key, value in expected.items():
            assert_matches(parsed[key], value, f"{path}.{key}")
    elif isinstance(expected, list):
        assert list(parsed) == expected, path
    else:
        assert parsed == expected, path


# What robot protocol 9 writes differently from v10 (protocol/robot_v9.py): each has a vector.
V9_DIFFERENCES = {"robot_v9.RobotState", "robot_v9.MoveRequest",
                  "robot_v9.LoadModelLibraryRequest", "robot_v9.LoadModelLibraryResponse",
                  "robot_v9.GetRobotModelRequest"}
# And what 5 and 6 write differently from 7 (protocol/robot_v5.py, robot_v6.py).
V5_DIFFERENCES = {"robot_v5.GetCartesianLimitRequest", "robot_v5.GetCartesianLimitResponse",
                  "robot_v5.SetFiltersRequest", "robot_v5.SetFiltersResponse",
                  "robot_v5.MoveResponse", "robot_v5.LoadModelLibraryRequest",
                  "robot_v6.LoadModelLibraryRequest"}


def struct_of(doc):
    """The declaration a vector names: a franka_sim.protocol name, or module.name beside it."""
    module, _, name = doc["struct"].rpartition(".")
    return getattr(getattr(protocol, module) if module else protocol, name)


def test_there_is_a_golden_vector_for_every_message_kind():
    structs = {json.loads(p.read_text())["struct"] for p in GOLDEN_FILES}
    messages = {name for name in protocol.__all__ if name.endswith(("Request", "Response"))}
    expected = (messages | {"RobotState", "RobotCommand", "GripperState", "VacuumGripperState"}
                | V9_DIFFERENCES
                | V5_DIFFERENCES)
    assert structs == expected


@pytest.mark.parametrize("path", GOLDEN_FILES, ids=lambda p: p.stem)
def test_construct_builds_the_golden_bytes(path):
    doc = load(path)
    assert struct_of(doc).build(doc["fields"]).hex() == doc["hex"]
    assert len(bytes.fromhex(doc["hex"])) == doc["size"]


@pytest.mark.parametrize("path", GOLDEN_FILES, ids=lambda p: p.stem)
def test_construct_parses_the_golden_values(path):
    doc = load(path)
    assert_matches(struct_of(doc).parse(bytes.fromhex(doc["hex"])), doc["fields"])


def test_a_v9_client_gets_the_golden_v10_state_as_the_golden_v9_state():
    """The same values in both vectors (float32-exact): widening is all the dialect does."""
    v10 = bytes.fromhex(load(SPECS / "golden" / "robot_state.json")["hex"])
    v9 = bytes.fromhex(load(SPECS / "golden" / "robot_v9_state.json")["hex"])
    assert protocol.robot_v9.Dialect().state(v10) == v9


def test_a_v5_client_reads_the_v10_robots_move_status_by_its_name():
    """kCommandNotPossibleRejected is 5 in v10 and 3 in v5 (two safety statuses came later)."""
    from franka_sim.protocol import robot_messages
    from franka_sim.protocol.enums import Command, MoveStatus

    v10 = robot_messages.build_response(Command.Move, 5, MoveStatus.kCommandNotPossibleRejected)
    v5 = bytes.fromhex(load(SPECS / "golden" / "robot_v5_move_response.json")["hex"])
    assert protocol.robot_v5.Dialect().reply(v10) == v5


STATE_ENUMS = {
    "motion_generator_mode": MotionGeneratorMode,
    "controller_mode": ControllerMode,
    "robot_mode": RobotMode,
}


def test_state_buffer_packs_the_golden_state():
    doc = load(SPECS / "golden" / "robot_state.json")
    buf = StateBuffer()
    for name, value in doc["fields"].items():
        value = STATE_ENUMS[name][value] if name in STATE_ENUMS else value
        getattr(buf, name)[...] = value
    assert buf.pack().hex() == doc["hex"]
    state = decode_state(bytes.fromhex(doc["hex"]))
    assert state["robot_mode"] == RobotMode.kMove
    np.testing.assert_array_equal(state["q"], doc["fields"]["q"])


def test_command_codec_matches_the_golden_command():
    doc = load(SPECS / "golden" / "robot_command.json")
    assert encode_command(**doc["fields"]).hex() == doc["hex"]
    command = decode_command(bytes.fromhex(doc["hex"]))
    for name, value in doc["fields"].items():
        np.testing.assert_array_equal(command[name], value, err_msg=name)


def test_gripper_state_codec_matches_the_golden_state():
    doc = load(SPECS / "golden" / "gripper_state.json")
    buf = GripperStateBuffer()
    for name, value in doc["fields"].items():
        getattr(buf, name)[...] = value
    assert buf.pack().hex() == doc["hex"]
    assert decode_gripper_state(buf.pack())["temperature"] == doc["fields"]["temperature"]


def test_golden_files_are_what_make_golden_writes():
    spec = importlib.util.spec_from_file_location("make_golden", SPECS / "make_golden.py")
    make_golden = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_golden)
    assert make_golden.main(["--check"]) == 0
