"""One arm's parts built from a Config: what the server wires to its sockets and what replay
runs without any. Built in one place so that a replayed run starts from the very robot the
recorded one did."""

from __future__ import annotations

import numpy as np

from franka_sim.config import Config
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.mujoco_backend import MujocoBackend
from franka_sim.physics.scene import check_scene, default_scene_path
from franka_sim.robot.core import RobotCore
from franka_sim.robot.cycle import RobotCycle
from franka_sim.robot.gripper import Gripper
from franka_sim.robot.requests import RequestHandler
from franka_sim.robot.session import Session, gripper_session, robot_session


class ArmParts:
    """The description, the core, the Hand (None: --no-gripper) and the scene of one arm."""

    def __init__(self, config: Config) -> None:
        self.config = config
        self.urdf_text = (
            config.urdf.read_text() if config.urdf is not None else default_urdf_text()
        )
        self.description = load_arm_description(self.urdf_text)
        self.q0 = np.array(config.q0, dtype=float)
        self.core = RobotCore(
            self.description, self.q0, enforce_comm_constraints=config.enforce_comm_constraints,
            enforce_motion_limits=config.enforce_motion_limits,
            joint_discontinuity_scale=config.joint_discontinuity_scale,
        )
        self.scene = config.scene if config.scene is not None else default_scene_path()
        check_scene(self.description, self.scene, fingers=config.gripper)  # SceneError: say so now
        # The Hand: without it (--no-gripper) nothing listens on 1338 and the hand is rigid.
        self.gripper = Gripper() if config.gripper else None

    def make_physics(self) -> MujocoBackend:
        """The world (in the thread that will own it)."""
        return MujocoBackend(self.description, self.q0, scene_xml=self.scene,
                             fingers=self.config.gripper)

    def make_cycle(self, physics, hand_state_wanted=lambda: True) -> RobotCycle:
        return RobotCycle(self.core, physics, self.gripper, hand_state_wanted=hand_state_wanted)

    def robot_session(self) -> Session:
        return robot_session(RequestHandler(self.core, self.urdf_text.encode()))

    def gripper_session(self) -> Session:
        return gripper_session(self.gripper)
