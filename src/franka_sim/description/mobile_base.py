"""The simulated mobile base: its served URDF and the figures its drive and body use.

libfranka (>= 0.21) calls a robot mobile when its URDF's robot name starts with "tmr", and
then reads four joint values by their suffixes `_joint_0` .. `_joint_3`: front module steer,
front drive, rear steer, rear drive (`franka::MobileModel`). The URDF below is this project's
own small base with that shape: a chassis and two swerve modules on its long axis, each a
continuous steering joint about z carrying a wheel on a continuous drive joint about its y
axis. Dimensions, masses and limits are our own round figures, not those of any real base.
"""

from __future__ import annotations

BASE_NAME = "tmr_sim"  # "tmr...": libfranka reports isMobileRobot() and refuses loadModel()
JOINT_NAMES = tuple(f"{BASE_NAME}_joint_{i}" for i in range(4))

# Where the swerve modules sit in the base frame (x forward, y left, z up; origin on the
# floor under the chassis centre), m, and the wheel's radius.
FRONT_MODULE = (0.25, 0.0)
REAR_MODULE = (-0.25, 0.0)
WHEEL_RADIUS = 0.08

# The chassis (a box on the floor clearance) and the column the arms' mount stands on, m.
CHASSIS_HALF_SIZE = (0.35, 0.25, 0.12)
CHASSIS_CLEARANCE = 0.04
COLUMN_HALF_SIZE = (0.1, 0.42)  # x, y; its height reaches up to the arms' mount

# What the base follows of a commanded body twist (our figures, documented in
# docs/deviations.md): planar speed, yaw rate, and how fast either may change.
MAX_SPEED = 1.0  # m/s, |(vx, vy)|
MAX_ACCELERATION = 1.0  # m/s²
MAX_YAW_RATE = 1.5  # rad/s
MAX_YAW_ACCELERATION = 3.0  # rad/s²


def _module(name: str, x: float, y: float) -> str:
    steer, drive = name
    return f"""
  <joint name="{BASE_NAME}_joint_{steer}" type="continuous">
    <parent link="{BASE_NAME}_base"/>
    <child link="{BASE_NAME}_module_{steer}"/>
    <origin xyz="{x} {y} {WHEEL_RADIUS}" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit effort="40" velocity="6"/>
  </joint>
  <link name="{BASE_NAME}_module_{steer}">
    <inertial><origin xyz="0 0 0.06"/><mass value="3.0"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.008"/></inertial>
  </link>
  <joint name="{BASE_NAME}_joint_{drive}" type="continuous">
    <parent link="{BASE_NAME}_module_{steer}"/>
    <child link="{BASE_NAME}_wheel_{steer}"/>
    <origin xyz="0 0 0" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit effort="60" velocity="15"/>
  </joint>
  <link name="{BASE_NAME}_wheel_{steer}">
    <inertial><origin xyz="0 0 0"/><mass value="2.0"/>
      <inertia ixx="0.004" ixy="0" ixz="0" iyy="0.0064" iyz="0" izz="0.004"/></inertial>
  </link>"""


def base_urdf_text() -> str:
    """The URDF the base serves on GetRobotModel."""
    hx, hy, hz = CHASSIS_HALF_SIZE
    return f"""<?xml version="1.0"?>
<robot name="{BASE_NAME}">
  <link name="{BASE_NAME}_base">
    <inertial><origin xyz="0 0 {CHASSIS_CLEARANCE + hz}"/><mass value="120.0"/>
      <inertia ixx="3.0" ixy="0" ixz="0" iyy="5.5" iyz="0" izz="7.0"/></inertial>
    <visual><origin xyz="0 0 {CHASSIS_CLEARANCE + hz}"/>
      <geometry><box size="{2 * hx} {2 * hy} {2 * hz}"/></geometry></visual>
  </link>{_module("01", *FRONT_MODULE)}{_module("23", *REAR_MODULE)}
</robot>
"""
