"""Write the golden byte vectors in golden/ (run: python protocol_specs/make_golden.py [--check]).

Deliberately independent of franka_sim: every value is placed with the standard ``struct``
module at the offset written in robot_v10.md, robot_v9.md, robot_v5.md, gripper_v3.md or
vacuum_gripper_v1.md, and enum names are translated with
tables restated here. The tests then require the construct declarations to build exactly these
bytes and to parse them back to these values, so a mistake would have to be made twice, in two
different notations, to go unnoticed. The script also checks that each layout covers every byte
of its message exactly once.

``--check`` regenerates in memory and fails if a file in golden/ differs.
"""

import json
import math
import re
import struct
import sys
from pathlib import Path

GOLDEN = Path(__file__).with_name("golden")
sys.path.insert(0, str(Path(__file__).parent))
from golden_tables import (  # noqa: E402  (beside this script, however it is loaded)
    COMMAND, GRIPPER_COMMAND, VACUUM_COMMAND, CONNECT_STATUS, BASE_STATUS,
    GETTER_SETTER_STATUS, GRIPPER_CONNECT_STATUS, GRIPPER_STATUS, VACUUM_STATUS,
    VACUUM_PROFILE, VACUUM_DEVICE_STATUS, STATUS_OF, MOVE_CONTROLLER_MODE,
    MOVE_MOTION_GENERATOR_MODE, STATE_ENUMS, STATE_LAYOUT, STATE_V9_LAYOUT, COMMAND_V9,
    COMMAND_V5, COMMAND_V6, GETTER_SETTER_STATUS_V5, MOVE_STATUS_V5, ARCHITECTURE_V9,
    SYSTEM_V9, LOAD_MODEL_LIBRARY_STATUS_V9, COMMAND_LAYOUT, ROBOT_HEADER, GRIPPER_HEADER,
)


def robot_enums(command):
    """Enum tables for a robot message: its command, its status, the Move request modes."""
    return {"header.command": COMMAND,
            "status": STATUS_OF.get(command, GETTER_SETTER_STATUS),
            "controller_mode": MOVE_CONTROLLER_MODE,
            "motion_generator_mode": MOVE_MOTION_GENERATOR_MODE}


def _get(fields, dotted):
    for key in dotted.split("."):
        fields = fields[key]
    return fields


def pack(size, layout, fields, enums):
    """Place every field at its offset; fail on gaps or overlaps."""
    buf, cover = bytearray(size), bytearray(size)
    for offset, key, fmt in layout:
        value = _get(fields, key)
        if isinstance(value, str) and fmt != "s*":
            value = enums[key][value]
        if fmt == "s*":  # text to the end of the message (URDF)
            value, fmt = [value.encode()], f"{len(value.encode())}s"
        values = value if isinstance(value, list) else [value]
        struct.pack_into("<" + fmt, buf, offset, *values)
        for i in range(offset, offset + struct.calcsize("<" + fmt)):
            cover[i] += 1
    assert all(c == 1 for c in cover), f"layout does not cover each byte once: {layout}"
    return bytes(buf)


def header(command, command_id, size):
    return {"command": command, "command_id": command_id, "size": size}


def robot_state_fields():
    """Distinct, float32-exact values per element, so any offset slip changes the bytes."""
    special = {
        "message_id": 0x0123456789ABCDEF, "motion_generator_mode": "kJointVelocity",
        "controller_mode": "kCartesianImpedance", "robot_mode": "kMove",
        "errors": [i in (0, 25, 31, 34, 40) for i in range(41)],
        "reflex_reason": [i in (6, 7) for i in range(41)], "control_command_success_rate": 0.75,
    }
    fields = {}
    for k, (_, name, fmt) in enumerate(STATE_LAYOUT):
        vals = [(-1) ** i * ((k + 1) + i / 8) for i in range(int(fmt[:-1] or 1))]
        fields[name] = special.get(name, vals if fmt[:-1] else vals[0])
    return fields


def messages():
    """(file stem, struct name in franka_sim.protocol, size, layout, fields, enums)."""
    two_pi = 2 * math.pi
    dev = {"translation": 10.0, "rotation": 3.12, "elbow": two_pi}
    status_only = ROBOT_HEADER + [(12, "status", "B")]
    yield ("robot_state", "RobotState", 1377, STATE_LAYOUT, robot_state_fields(),
           STATE_ENUMS)
    yield ("robot_command", "RobotCommand", 371, COMMAND_LAYOUT, {
        "message_id": 4242, "q_c": [0.1 * i for i in range(7)],
        "dq_c": [-0.01 * i for i in range(7)],
        "O_T_EE_c": [1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0.3, 0.0, 0.5, 1.0],
        "O_dP_EE_c": [0.5, -0.5, 0.25, 0.0, 1e-3, -1e-3], "elbow_c": [0.75, -1.0],
        "valid_elbow": True, "motion_generation_finished": False,
        "tau_J_d": [1.5, -2.5, 3.5, -4.5, 5.5, -6.5, 7.5], "torque_command_finished": True,
    }, {})
    yield ("robot_connect_request", "ConnectRequest", 16,
           ROBOT_HEADER + [(12, "version", "H"), (14, "udp_port", "H")],
           {"header": header("Connect", 0, 16), "version": 10, "udp_port": 54321},
           robot_enums("Connect"))
    yield ("robot_connect_response", "ConnectResponse", 15,
           status_only + [(13, "version", "H")],
           {"header": header("Connect", 0, 15), "status": "kSuccess", "version": 10},
           robot_enums("Connect"))
    yield ("robot_move_request", "MoveRequest", 125, ROBOT_HEADER + [
        (12, "controller_mode", "I"), (16, "motion_generator_mode", "I"),
        (20, "maximum_path_deviation.translation", "d"),
        (28, "maximum_path_deviation.rotation", "d"), (36, "maximum_path_deviation.elbow", "d"),
        (44, "maximum_goal_pose_deviation.translation", "d"),
        (52, "maximum_goal_pose_deviation.rotation", "d"),
        (60, "maximum_goal_pose_deviation.elbow", "d"),
        (68, "use_async_motion_generator", "?"), (69, "maximum_velocity", "7d")], {
        "header": header("Move", 2, 125), "controller_mode": "kJointImpedance",
        "motion_generator_mode": "kJointVelocity", "maximum_path_deviation": dict(dev),
        "maximum_goal_pose_deviation": dict(dev), "use_async_motion_generator": True,
        "maximum_velocity": [2.0, 2.0, 2.0, 2.0, 2.5, 2.5, 2.5]}, robot_enums("Move"))
    thresholds = [  # SetCollisionBehavior payload, in wire order
        ("lower_torque_thresholds_acceleration", 7), ("upper_torque_thresholds_acceleration", 7),
        ("lower_torque_thresholds_nominal", 7), ("upper_torque_thresholds_nominal", 7),
        ("lower_force_thresholds_acceleration", 6), ("upper_force_thresholds_acceleration", 6),
        ("lower_force_thresholds_nominal", 6), ("upper_force_thresholds_nominal", 6),
    ]
    layout, fields, offset = list(ROBOT_HEADER), {}, 12
    for k, (name, n) in enumerate(thresholds):
        layout.append((offset, name, f"{n}d"))
        fields[name] = [10.0 * (k + 1) + i for i in range(n)]
        offset += 8 * n
    yield ("robot_set_collision_behavior_request", "SetCollisionBehaviorRequest", 428, layout,
           {"header": header("SetCollisionBehavior", 3, 428), **fields},
           robot_enums("SetCollisionBehavior"))
    simple = [  # (file stem, command, request size, payload layout, payload fields)
        ("set_joint_impedance", "SetJointImpedance", 68, [(12, "K_theta", "7d")],
         {"K_theta": [3000.0, 3000.0, 3000.0, 2500.0, 2500.0, 2000.0, 2000.0]}),
        ("set_cartesian_impedance", "SetCartesianImpedance", 60, [(12, "K_x", "6d")],
         {"K_x": [3000.0, 3000.0, 3000.0, 300.0, 300.0, 300.0]}),
        ("set_guiding_mode", "SetGuidingMode", 19, [(12, "guiding_mode", "6?"),
                                                    (18, "nullspace", "?")],
         {"guiding_mode": [True, True, False, True, False, True], "nullspace": True}),
        ("set_ee_to_k", "SetEEToK", 140, [(12, "EE_T_K", "16d")],
         {"EE_T_K": [1.0, 0, 0, 0, 0, 1.0, 0, 0, 0, 0, 1.0, 0, 0.01, 0.02, 0.03, 1.0]}),
        ("set_ne_to_ee", "SetNEToEE", 140, [(12, "NE_T_EE", "16d")],
         {"NE_T_EE": [0.7071, -0.7071, 0, 0, 0.7071, 0.7071, 0, 0, 0, 0, 1.0, 0,
                      0, 0, 0.1034, 1.0]}),
        ("set_load", "SetLoad", 116,
         [(12, "m_load", "d"), (20, "F_x_Cload", "3d"), (44, "I_load", "9d")],
         {"m_load": 0.5, "F_x_Cload": [0.0, 0.01, 0.05],
          "I_load": [1e-3, 0, 0, 0, 2e-3, 0, 0, 0, 3e-3]}),
        ("stop_move", "StopMove", 12, [], {}),
        ("automatic_error_recovery", "AutomaticErrorRecovery", 12, [], {}),
        ("get_robot_model", "GetRobotModel", 12, [], {}),
    ]
    statuses = {"StopMove": "kSuccess", "AutomaticErrorRecovery":
                "kManualErrorRecoveryRequiredRejected", "SetLoad": "kInvalidArgumentRejected",
                "GetRobotModel": "kSuccess"}
    for cid, (stem, cmd, size, payload, values) in enumerate(simple, start=4):
        yield (f"robot_{stem}_request", f"{cmd}Request", size, ROBOT_HEADER + payload,
               {"header": header(cmd, cid, size), **values}, robot_enums(cmd))
        if cmd != "GetRobotModel":
            yield (f"robot_{stem}_response", f"{cmd}Response", 13, status_only,
                   {"header": header(cmd, cid, 13), "status": statuses.get(cmd, "kSuccess")},
                   robot_enums(cmd))
    yield ("robot_move_response", "MoveResponse", 13, status_only,
           {"header": header("Move", 2, 13), "status": "kMotionStarted"}, robot_enums("Move"))
    yield ("robot_set_collision_behavior_response", "SetCollisionBehaviorResponse", 13,
           status_only, {"header": header("SetCollisionBehavior", 3, 13),
                         "status": "kCommandRejectedDueToActivatedSafetyFunctions"},
           robot_enums("SetCollisionBehavior"))
    urdf = '<robot name="fr3"><link name="link0"/></robot>'
    yield ("robot_get_robot_model_response", "GetRobotModelResponse", 13 + len(urdf),
           status_only + [(13, "urdf", "s*")],
           {"header": header("GetRobotModel", 12, 13 + len(urdf)), "status": "kSuccess",
            "urdf": urdf}, robot_enums("GetRobotModel"))
    yield from robot_v9_messages()
    yield from robot_v5_messages()
    yield from gripper_messages()
    yield from vacuum_gripper_messages()


def robot_v9_messages():
    """What robot protocol 9 writes differently (robot_v9.md); the rest is v10's bytes."""
    enums = {"header.command": COMMAND_V9, "status": BASE_STATUS,
             "controller_mode": MOVE_CONTROLLER_MODE,
             "motion_generator_mode": MOVE_MOTION_GENERATOR_MODE,
             "architecture": ARCHITECTURE_V9, "system": SYSTEM_V9}
    v10 = robot_state_fields()  # the same values: a v9 state is the v10 state widened
    yield ("robot_v9_state", "robot_v9.RobotState", 2373, STATE_V9_LAYOUT,
           {name: v10[name] for _, name, _ in STATE_V9_LAYOUT}, STATE_ENUMS)
    dev = {"translation": 10.0, "rotation": 3.12, "elbow": 2 * math.pi}
    yield ("robot_v9_move_request", "robot_v9.MoveRequest", 68, ROBOT_HEADER + [
        (12, "controller_mode", "I"), (16, "motion_generator_mode", "I"),
        (20, "maximum_path_deviation.translation", "d"),
        (28, "maximum_path_deviation.rotation", "d"), (36, "maximum_path_deviation.elbow", "d"),
        (44, "maximum_goal_pose_deviation.translation", "d"),
        (52, "maximum_goal_pose_deviation.rotation", "d"),
        (60, "maximum_goal_pose_deviation.elbow", "d")], {
        "header": header("Move", 2, 68), "controller_mode": "kCartesianImpedance",
        "motion_generator_mode": "kCartesianPosition", "maximum_path_deviation": dict(dev),
        "maximum_goal_pose_deviation": dict(dev)}, enums)
    yield ("robot_v9_load_model_library_request", "robot_v9.LoadModelLibraryRequest", 14,
           ROBOT_HEADER + [(12, "architecture", "B"), (13, "system", "B")],
           {"header": header("LoadModelLibrary", 7, 14), "architecture": "kX64",
            "system": "kLinux"}, enums)
    library = "\x7fELF and the rest of the library"
    yield ("robot_v9_load_model_library_response", "robot_v9.LoadModelLibraryResponse",
           13 + len(library), ROBOT_HEADER + [(12, "status", "B"), (13, "library", "s*")],
           {"header": header("LoadModelLibrary", 7, 13 + len(library)), "status": "kSuccess",
            "library": library}, {**enums, "status": LOAD_MODEL_LIBRARY_STATUS_V9})
    yield ("robot_v9_get_robot_model_request", "robot_v9.GetRobotModelRequest", 12,
           ROBOT_HEADER, {"header": header("GetRobotModel", 8, 12)}, enums)


def robot_v5_messages():
    """What robot protocols 5 and 6 write differently from 7 (robot_v5.md)."""
    enums = {"header.command": COMMAND_V5, "status": GETTER_SETTER_STATUS_V5,
             "architecture": ARCHITECTURE_V9, "system": SYSTEM_V9}
    yield ("robot_v5_get_cartesian_limit_request", "robot_v5.GetCartesianLimitRequest", 16,
           ROBOT_HEADER + [(12, "id", "i")],
           {"header": header("GetCartesianLimit", 3, 16), "id": -2}, enums)
    frame = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.25, -0.5, 0.75, 1.0]
    yield ("robot_v5_get_cartesian_limit_response", "robot_v5.GetCartesianLimitResponse", 166,
           ROBOT_HEADER + [(12, "status", "B"), (13, "object_world_size", "3d"),
                           (37, "object_frame", "16d"), (165, "object_activation", "?")],
           {"header": header("GetCartesianLimit", 3, 166), "status": "kSuccess",
            "object_world_size": [0.5, 1.25, 2.0], "object_frame": frame,
            "object_activation": True}, enums)
    names = ["joint_position_filter_frequency", "joint_velocity_filter_frequency",
             "cartesian_position_filter_frequency", "cartesian_velocity_filter_frequency",
             "controller_filter_frequency"]
    yield ("robot_v5_set_filters_request", "robot_v5.SetFiltersRequest", 52,
           ROBOT_HEADER + [(12 + 8 * i, name, "d") for i, name in enumerate(names)],
           {"header": header("SetFilters", 4, 52),
            **{name: 100.0 * (i + 1) for i, name in enumerate(names)}}, enums)
    yield ("robot_v5_set_filters_response", "robot_v5.SetFiltersResponse", 13,
           ROBOT_HEADER + [(12, "status", "B")],
           {"header": header("SetFilters", 4, 13), "status": "kInvalidArgumentRejected"}, enums)
    yield ("robot_v5_move_response", "robot_v5.MoveResponse", 13,
           ROBOT_HEADER + [(12, "status", "B")],
           {"header": header("Move", 5, 13), "status": "kCommandNotPossibleRejected"},
           {**enums, "status": MOVE_STATUS_V5})
    yield ("robot_v5_load_model_library_request", "robot_v5.LoadModelLibraryRequest", 14,
           ROBOT_HEADER + [(12, "architecture", "B"), (13, "system", "B")],
           {"header": header("LoadModelLibrary", 6, 14), "architecture": "kARM64",
            "system": "kLinux"}, enums)
    yield ("robot_v6_load_model_library_request", "robot_v6.LoadModelLibraryRequest", 14,
           ROBOT_HEADER + [(12, "architecture", "B"), (13, "system", "B")],
           {"header": header("LoadModelLibrary", 6, 14), "architecture": "kX64",
            "system": "kLinux"}, {**enums, "header.command": COMMAND_V6})


def gripper_messages():
    enums = {"header.command": GRIPPER_COMMAND, "status": GRIPPER_STATUS}
    status = GRIPPER_HEADER + [(10, "status", "H")]
    yield ("gripper_state", "GripperState", 23,
           [(0, "message_id", "I"), (4, "width", "d"), (12, "max_width", "d"),
            (20, "is_grasped", "?"), (21, "temperature", "H")],
           {"message_id": 123456, "width": 0.0405, "max_width": 0.0805, "is_grasped": True,
            "temperature": 31}, {})
    yield ("gripper_connect_request", "GripperConnectRequest", 14,
           GRIPPER_HEADER + [(10, "version", "H"), (12, "udp_port", "H")],
           {"header": header("Connect", 0, 14), "version": 3, "udp_port": 40001}, enums)
    yield ("gripper_connect_response", "GripperConnectResponse", 14,
           status + [(12, "version", "H")],
           {"header": header("Connect", 0, 14), "status": "kSuccess", "version": 3},
           {**enums, "status": GRIPPER_CONNECT_STATUS})
    yield ("gripper_homing_request", "GripperHomingRequest", 10, GRIPPER_HEADER,
           {"header": header("Homing", 1, 10)}, enums)
    yield ("gripper_grasp_request", "GripperGraspRequest", 50, GRIPPER_HEADER + [
        (10, "width", "d"), (18, "epsilon_inner", "d"), (26, "epsilon_outer", "d"),
        (34, "speed", "d"), (42, "force", "d")],
        {"header": header("Grasp", 2, 50), "width": 0.02, "epsilon_inner": 0.005,
         "epsilon_outer": 0.005, "speed": 0.1, "force": 60.0}, enums)
    yield ("gripper_move_request", "GripperMoveRequest", 26,
           GRIPPER_HEADER + [(10, "width", "d"), (18, "speed", "d")],
           {"header": header("Move", 3, 26), "width": 0.08, "speed": 0.05}, enums)
    yield ("gripper_stop_request", "GripperStopRequest", 10, GRIPPER_HEADER,
           {"header": header("Stop", 4, 10)}, enums)
    for cid, (cmd, st) in enumerate([("Homing", "kSuccess"), ("Grasp", "kUnsuccessful"),
                                     ("Move", "kSuccess"), ("Stop", "kSuccess")], start=1):
        yield (f"gripper_{cmd.lower()}_response", "GripperCommandResponse", 12, status,
               {"header": header(cmd, cid, 12), "status": st}, enums)


def vacuum_gripper_messages():
    """vacuum_gripper_v1.md: the Hand's header, its own commands and a 16-byte state."""
    enums = {"header.command": VACUUM_COMMAND, "status": VACUUM_STATUS,
             "profile": VACUUM_PROFILE, "device_status": VACUUM_DEVICE_STATUS}
    status = GRIPPER_HEADER + [(10, "status", "H")]
    yield ("vacuum_gripper_state", "VacuumGripperState", 16,
           [(0, "message_id", "I"), (4, "in_control_range", "?"), (5, "part_detached", "?"),
            (6, "part_present", "?"), (7, "device_status", "B"), (8, "actual_power", "i"),
            (12, "vacuum", "i")],
           {"message_id": 654321, "in_control_range": True, "part_detached": False,
            "part_present": True, "device_status": "kYellow", "actual_power": 37,
            "vacuum": 612}, enums)
    yield ("vacuum_gripper_connect_request", "VacuumGripperConnectRequest", 14,
           GRIPPER_HEADER + [(10, "version", "H"), (12, "udp_port", "H")],
           {"header": header("Connect", 0, 14), "version": 1, "udp_port": 40002}, enums)
    yield ("vacuum_gripper_connect_response", "VacuumGripperConnectResponse", 14,
           status + [(12, "version", "H")],
           {"header": header("Connect", 0, 14), "status": "kIncompatibleLibraryVersion",
            "version": 1}, {**enums, "status": CONNECT_STATUS})
    yield ("vacuum_gripper_vacuum_request", "VacuumGripperVacuumRequest", 20,
           GRIPPER_HEADER + [(10, "vacuum", "B"), (11, "profile", "B"), (12, "timeout", "q")],
           {"header": header("Vacuum", 1, 20), "vacuum": 75, "profile": "kP2",
            "timeout": 1000}, enums)
    yield ("vacuum_gripper_drop_off_request", "VacuumGripperDropOffRequest", 18,
           GRIPPER_HEADER + [(10, "timeout", "q")],
           {"header": header("DropOff", 2, 18), "timeout": 2500}, enums)
    yield ("vacuum_gripper_stop_request", "VacuumGripperStopRequest", 10, GRIPPER_HEADER,
           {"header": header("Stop", 3, 10)}, enums)
    for cid, (cmd, st) in enumerate([("Vacuum", "kUnsuccessful"), ("DropOff", "kSuccess"),
                                     ("Stop", "kAborted")], start=1):
        stem = {"DropOff": "drop_off"}.get(cmd, cmd.lower())
        yield (f"vacuum_gripper_{stem}_response", "VacuumGripperCommandResponse", 12, status,
               {"header": header(cmd, cid, 12), "status": st}, enums)


def _one_line_arrays(text):
    """Keep number/bool arrays on one line so a 1377-byte state stays readable."""
    return re.sub(r"\[([^\[\]{}\"]*)\]",
                  lambda m: "[" + ", ".join(v.strip() for v in m.group(1).split(",")) + "]", text)


def render():
    """{file name: JSON text} for every golden vector."""
    out = {}
    for stem, struct_name, size, layout, fields, enums in messages():
        doc = {"struct": struct_name, "size": size, "fields": fields,
               "hex": pack(size, layout, fields, enums).hex()}
        text = [key for _, key, fmt in layout if fmt == "s*"]
        if text:
            doc["text_fields"] = text  # JSON has no bytes; these are UTF-8 text
        out[f"{stem}.json"] = _one_line_arrays(json.dumps(doc, indent=1)) + "\n"
    return out


def main(argv):
    files = render()
    if "--check" in argv:
        stale = [n for n, t in files.items()
                 if not (GOLDEN / n).exists() or (GOLDEN / n).read_text() != t]
        extra = {p.name for p in GOLDEN.glob("*.json")} - set(files)
        if stale or extra:
            print("golden/ is out of date:", sorted(stale), sorted(extra))
            return 1
        return 0
    GOLDEN.mkdir(exist_ok=True)
    for name, text in files.items():
        (GOLDEN / name).write_text(text)
    print(f"wrote {len(files)} golden vectors to {GOLDEN}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
