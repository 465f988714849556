"""The Hand's fingers are coupled, as one mechanism drives both on the robot: a cube grasped
12 mm off the Hand's axis ends centred between the fingers, and stays centred as it is lifted
(pylibfranka, lockstep; the positions read through the control API)."""

from __future__ import annotations


import numpy as np
import pylibfranka

from franka_sim.control import Control
from franka_sim.testing import running_sim
from support.clients import connect

import pick_and_place as pp

OFF_AXIS = 0.012  # m along the closing direction (the base's y at the grasp pose)


def test_an_off_centre_cube_is_grasped_centred_and_lifted_so():
    with running_sim("--clock", "lockstep") as sim:
        control = Control(sim.host)
        control.set_pose("cube", (pp.CUBE + [0.0, OFF_AXIS, 0.0]).tolist())
        robot, gripper = connect(sim.host), pylibfranka.Gripper(sim.host)
        robot.set_collision_behavior([40.0] * 7, [40.0] * 7, [40.0] * 6, [40.0] * 6)
        gripper.homing()
        above, at = pp.poses_over(pp.CUBE, pp.READY)  # the Hand's axis over y = 0
        pp.move_joints(robot, pp.READY)
        pp.move_joints(robot, above)
        pp.move_joints(robot, at, max_speed=0.3)
        assert control.pose("cube")["position"][1] == OFF_AXIS  # untouched until the grasp
        assert gripper.grasp(pp.CUBE_SIZE, pp.SPEED, pp.GRASP_FORCE, 0.005, 0.005)
        axis = pp.ee_pose(np.array(robot.read_once().q))[1, 3]
        grasped = _centring(control, axis)
        pp.move_joints(robot, above, max_speed=0.3)
        lifted = _centring(control, pp.ee_pose(np.array(robot.read_once().q))[1, 3])
        assert gripper.read_once().is_grasped
        del gripper, robot
    for fingers, cube, _ in (grasped, lifted):
        assert abs(fingers) < 5e-4, f"fingers {fingers * 1e3:.2f} mm off the axis"
        assert abs(cube) < 5e-4, f"cube {cube * 1e3:.2f} mm off the axis"
    assert lifted[2] > pp.CUBE[2] + 0.1  # it came up with the Hand


def _centring(control: Control, axis_y: float) -> tuple[float, float, float]:
    """(the fingers' midpoint, the cube's centre) along y from the Hand's axis, the cube's z."""
    y1, y2 = (control.pose(name)["position"][1] for name in ("finger1", "finger2"))
    cube = control.pose("cube")["position"]
    return 0.5 * (y1 + y2) - axis_y, cube[1] - axis_y, cube[2]
