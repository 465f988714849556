"""Parse the URDF the simulator serves into plain numpy data.

The same text goes to the client (libfranka builds its Pinocchio `Model` from it) and, through
this module, into our MuJoCo scene and our numpy kinematics, so both sides agree by
construction. The parser therefore also enforces what libfranka itself requires of a served
URDF (docs/figures.md, "What libfranka requires of the served URDF"): a description that would
make the client throw is rejected here, at start-up, with a `DescriptionError` that says why,
instead of surfacing later as an opaque client-side failure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np

from franka_sim.description.xml_tree import Element, XmlError, parse
from franka_sim.package_files import PACKAGE_DIR

ARM_DOF = 7
FLANGE_LINK = "link8"  # libfranka looks the flange frame up by this exact name
ACCELEROMETER_TOP = tuple(f"link{i}_accelerometer_top" for i in range(6))
ACCELEROMETER_BOTTOM = tuple(f"link{i}_accelerometer_bottom" for i in range(6))


class DescriptionError(ValueError):
    """The URDF cannot describe an FR3 arm that libfranka (and this simulator) would accept."""


def _frozen(values) -> np.ndarray:
    array = np.array(values, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)  # numpy fields: identity, not value, equality
class Inertial:
    """A link's rigid-body inertia, as URDF states it (mass, CoM frame, tensor about the CoM)."""

    mass: float
    com: np.ndarray  # (3,) CoM position in the link frame
    rotation: np.ndarray  # (3,3) orientation of the inertia axes in the link frame (origin rpy)
    inertia: np.ndarray  # (3,3) about the CoM, in those axes

    @property
    def inertia_in_link(self) -> np.ndarray:
        """The tensor about the CoM expressed in link-frame axes (what MuJoCo's fullinertia wants)."""
        return self.rotation @ self.inertia @ self.rotation.T


@dataclass(frozen=True)
class JointLimits:
    lower: float
    upper: float
    effort: float
    velocity: float
    velocity_offset: float  # position-based velocity law (tests/data/fr3_limits.md)
    deceleration_limit: float
    soft_lower: float | None = None  # <safety_controller>: the datasheet range
    soft_upper: float | None = None


@dataclass(frozen=True, eq=False)
class ArmJoint:
    name: str
    index: int  # 1..7, position in the chain
    parent: str  # parent link name
    child: str  # child link name
    origin: np.ndarray  # (4,4) joint frame in the parent link frame, at q = 0
    axis: np.ndarray  # (3,) unit axis in the joint frame
    limits: JointLimits


@dataclass(frozen=True, eq=False)
class Frame:
    """Where a link sits on the kinematic chain: a fixed offset from one moving body.

    `body` 0 is the fixed base (the URDF root), `body` i is the child link of joint i.
    """

    name: str
    body: int
    offset: np.ndarray  # (4,4) pose in that body's frame


@dataclass(frozen=True, eq=False)
class ArmDescription:
    name: str
    root: str
    joints: tuple[ArmJoint, ...]  # joint1..joint7 in chain order
    frames: Mapping[str, Frame]  # every link, by name
    inertials: Mapping[str, Inertial]  # links that carry an <inertial>
    lower: np.ndarray = field(init=False)
    upper: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "lower", _frozen([j.limits.lower for j in self.joints]))
        object.__setattr__(self, "upper", _frozen([j.limits.upper for j in self.joints]))

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    def limit_array(self, attribute: str) -> np.ndarray:
        """One JointLimits attribute over the 7 joints, e.g. "velocity" or "soft_upper"."""
        return _frozen([getattr(j.limits, attribute) for j in self.joints])

# -- XML helpers -------------------------------------------------------------------------------
def _floats(text: str | None, count: int, what: str, default: str | None = None) -> list[float]:
    text = default if text is None else text
    try:
        values = [float(v) for v in (text or "").split()]
    except ValueError:
        raise DescriptionError(f"{what}: not numbers: {text!r}") from None
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise DescriptionError(f"{what}: expected {count} finite numbers, got {text!r}")
    return values


def _attr(element: Element, name: str, what: str) -> float:
    value = element.get(name)
    if value is None:
        raise DescriptionError(f"{what}: missing attribute {name!r}")
    return _floats(value, 1, f"{what} {name}")[0]


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF rpy: fixed-axis rotations about x, then y, then z (R = Rz·Ry·Rx)."""
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch),
                              math.sin(pitch), math.cos(yaw), math.sin(yaw))
    return np.array([
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ])


def _origin(parent: Element, what: str) -> np.ndarray:
    element = parent.find("origin")
    xyz = _floats(None if element is None else element.get("xyz"), 3, f"{what} origin xyz", "0 0 0")
    rpy = _floats(None if element is None else element.get("rpy"), 3, f"{what} origin rpy", "0 0 0")
    transform = np.eye(4)
    transform[:3, :3] = rpy_matrix(*rpy)
    transform[:3, 3] = xyz
    return transform


def _inertial(link: Element) -> Inertial | None:
    element = link.find("inertial")
    if element is None:
        return None
    what = f"link {link.get('name')!r} inertial"
    mass_el, inertia_el = element.find("mass"), element.find("inertia")
    if mass_el is None or inertia_el is None:
        raise DescriptionError(f"{what}: needs <mass> and <inertia>")
    origin = _origin(element, what)
    ixx, iyy, izz, ixy, ixz, iyz = (_attr(inertia_el, a, what)
                                    for a in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"))
    tensor = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]
    return Inertial(_attr(mass_el, "value", what), _frozen(origin[:3, 3]),
                    _frozen(origin[:3, :3]), _frozen(tensor))


def _limits(joint: Element, name: str) -> JointLimits:
    """The elements libfranka's JointVelocityLimitsConfig insists on for an arm joint."""
    limit, pbvl = joint.find("limit"), joint.find("position_based_velocity_limits")
    if limit is None:
        raise DescriptionError(f"joint {name!r}: missing <limit> (libfranka requires it)")
    if pbvl is None:
        raise DescriptionError(
            f"joint {name!r}: missing <position_based_velocity_limits> (libfranka requires it)")
    what = f"joint {name!r}"
    safety = joint.find("safety_controller")
    soft = {}
    if safety is not None:
        for key in ("soft_lower_limit", "soft_upper_limit"):
            if safety.get(key) is not None:
                soft[key] = _attr(safety, key, f"{what} safety_controller")
    effort = _attr(limit, "effort", f"{what} limit") if limit.get("effort") else math.inf
    return JointLimits(
        lower=_attr(limit, "lower", f"{what} limit"), upper=_attr(limit, "upper", f"{what} limit"),
        effort=effort, velocity=_attr(limit, "velocity", f"{what} limit"),
        velocity_offset=_attr(pbvl, "velocity_offset", f"{what} position_based_velocity_limits"),
        deceleration_limit=_attr(pbvl, "deceleration_limit",
                                 f"{what} position_based_velocity_limits"),
        soft_lower=soft.get("soft_lower_limit"), soft_upper=soft.get("soft_upper_limit"),
    )


# -- the parser --------------------------------------------------------------------------------
def load_arm_description(urdf_text: str) -> ArmDescription:
    """Parse and validate a served-URDF text; raises DescriptionError on anything unusable."""
    try:
        robot = parse(urdf_text)
    except XmlError as exc:
        raise DescriptionError(f"URDF is not well-formed XML: {exc}") from None
    if robot.tag != "robot":
        raise DescriptionError(f"root element is <{robot.tag}>, expected <robot>")
    name = robot.get("name", "")
    if name.startswith("tmr"):
        raise DescriptionError(f"robot name {name!r} starts with 'tmr': libfranka would treat "
                               "it as a mobile robot")

    links = {link.get("name"): link for link in robot.findall("link")}
    joints = robot.findall("joint")
    parent_joint: dict[str, Element] = {}
    for joint in joints:
        jname = joint.get("name")
        parent, child = joint.find("parent"), joint.find("child")
        if parent is None or child is None:
            raise DescriptionError(f"joint {jname!r}: needs <parent> and <child>")
        plink, clink = parent.get("link"), child.get("link")
        for link in (plink, clink):
            if link not in links:
                raise DescriptionError(f"joint {jname!r} refers to unknown link {link!r}")
        if clink in parent_joint:
            raise DescriptionError(f"link {clink!r} has two parent joints")
        parent_joint[clink] = joint

    # libfranka matches arm joints by substring, so every such joint must be a real arm joint.
    arm_elements: dict[int, Element] = {}
    for index in range(1, ARM_DOF + 1):
        matches = [j for j in joints if f"joint{index}" in (j.get("name") or "")]
        if len(matches) > 1:
            raise DescriptionError(
                f"joints {[j.get('name') for j in matches]} all contain 'joint{index}': libfranka "
                f"would take each for arm joint {index}; serve an arm-only URDF")
        if matches:
            arm_elements[index] = matches[0]
    missing = [f"joint{i}" for i in range(1, ARM_DOF + 1) if i not in arm_elements]
    if missing:
        raise DescriptionError(f"missing required joints: {', '.join(missing)}")
    limits = {i: _limits(el, el.get("name")) for i, el in arm_elements.items()}

    roots = [link for link in links if link not in parent_joint]
    if len(roots) != 1:
        raise DescriptionError(f"expected one root link, found {roots}")
    if FLANGE_LINK not in links:
        raise DescriptionError(f"no link named {FLANGE_LINK!r} (libfranka's flange frame)")

    # Walk down from the root: each link becomes (moving body, fixed offset on that body).
    moving = [j for j in joints if j.get("type") != "fixed"]
    if len(moving) != ARM_DOF or any(j.get("type") != "revolute" for j in moving):
        kinds = [(j.get("name"), j.get("type")) for j in moving]
        raise DescriptionError(f"expected exactly {ARM_DOF} revolute joints and nothing else "
                               f"movable, found {kinds}")
    children: dict[str, list[Element]] = {}
    for joint in joints:
        children.setdefault(joint.find("parent").get("link"), []).append(joint)
    frames: dict[str, Frame] = {roots[0]: Frame(roots[0], 0, _frozen(np.eye(4)))}
    chain: list[ArmJoint] = []
    stack = [roots[0]]
    while stack:
        link = stack.pop()
        for joint in children.get(link, []):
            jname, clink = joint.get("name"), joint.find("child").get("link")
            origin = _origin(joint, f"joint {jname!r}")
            if joint.get("type") == "fixed":
                base = frames[link]
                frames[clink] = Frame(clink, base.body, _frozen(base.offset @ origin))
            else:
                index = len(chain) + 1
                if frames[link].body != index - 1:
                    raise DescriptionError(f"joint {jname!r} branches off the serial chain")
                if joint is not arm_elements[index]:
                    raise DescriptionError(f"joint {jname!r} is number {index} along the chain "
                                           f"but is not named joint{index}")
                axis_el = joint.find("axis")  # URDF's default axis is x
                axis = np.array(_floats(None if axis_el is None else axis_el.get("xyz"), 3,
                                        f"joint {jname!r} axis", "1 0 0"))
                if np.linalg.norm(axis) == 0:
                    raise DescriptionError(f"joint {jname!r}: zero axis")
                chain.append(ArmJoint(jname, index, link, clink, _frozen(origin),
                                      _frozen(axis / np.linalg.norm(axis)), limits[index]))
                frames[clink] = Frame(clink, index, _frozen(np.eye(4)))
            stack.append(clink)
    if len(frames) != len(links):
        raise DescriptionError(f"links not connected to {roots[0]!r}: "
                               f"{sorted(set(links) - set(frames))}")
    if frames[FLANGE_LINK].body != ARM_DOF:
        raise DescriptionError(f"{FLANGE_LINK!r} must hang (fixed) below joint{ARM_DOF}")

    inertials = {n: i for n, link in links.items() if (i := _inertial(link)) is not None}
    return ArmDescription(name, roots[0], tuple(chain), MappingProxyType(frames),
                          MappingProxyType(inertials))


def default_urdf_text(robot: str = "fr3") -> str:
    """The packaged description of a robot kind (fr3, fer): installed package data first, then
    the source checkout."""
    packaged = PACKAGE_DIR / "urdf" / f"{robot}.urdf"
    if packaged.is_file():
        return packaged.read_text(encoding="utf-8")
    checkout = Path(__file__).resolve().parents[3] / "urdf" / f"{robot}.urdf"
    return checkout.read_text(encoding="utf-8")
