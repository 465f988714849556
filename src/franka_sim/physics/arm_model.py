"""One arm's MuJoCo bodies, built from the same ArmDescription the client receives.

The client's `franka::Model` is Pinocchio over the served URDF; we build MuJoCo's model from
that same parsed URDF (not from a hand-written MJCF) so kinematic origins, masses, CoMs, full
inertia tensors and joint axes agree by construction. MuJoCo is told to take the inertials
verbatim (physics/scene.py sets the compiler), and it stores each tensor in principal axes,
which is an exact change of basis.

What the URDF does not say and the physics needs is added here, each as a named table:
rotor inertia (armature), the Franka Hand's body on the flange (one rigid body, or with a tool's
moving parts built on it: physics/tool.py, e.g. the fingers of physics/fingers.py), collision
primitives and the sensor sites. Every name an arm adds carries
its prefix ("" for a lone arm), so several arms fit in one model.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.description import hand
from franka_sim.description.urdf import (ACCELEROMETER_BOTTOM, ACCELEROMETER_TOP, FLANGE_LINK,
                                         ArmDescription)
from franka_sim.physics.arm_look import (COLLISION_GROUP, add_hand_look, add_link_look,
                                         add_materials, add_mesh_look)
from franka_sim.physics.arm_meshes import HAND_MESH, HAND_YAW
from franka_sim.physics.tool import ToolMount

# Motor rotor inertia reflected through the gearbox, kg·m², per joint. libfranka's Model (the
# URDF's rigid bodies) leaves it out, but the physics needs it: without it joint 7 is so light
# that an explicit 1 kHz impedance loop diverges. Figures: the MuJoCo Menagerie FR3 model's
# armature (identified in torque control per its changelog). Drake quotes ~3× larger
# "reflected inertia provided by Franka"; the sources are not reconciled, and we take the
# smaller, torque-control-identified set (docs/figures.md, "Joint elasticity and rotor inertia").
ROTOR_INERTIA_FR3 = (0.195, 0.195, 0.195, 0.195, 0.074, 0.074, 0.074)

FLANGE_SITE = "flange"
HAND_BODY = "hand"

# Collision capsules (from, to, radius) in each link's own frame, m. Rough envelopes of the
# FR3's housings, our own sizing: good enough for contact with the environment and gross
# self-collision, not for clearance checks. The served URDF carries no collision geometry.
Capsule = tuple[tuple[float, float, float], tuple[float, float, float], float]
COLLISION_CAPSULES: dict[str, tuple[Capsule, ...]] = {
    "link0": (((-0.04, 0, 0.05), (0, 0, 0.16), 0.09),),  # base column
    "link1": (((0, 0, -0.19), (0, 0, -0.05), 0.07),),  # shoulder housing
    "link2": (((0, 0, -0.05), (0, 0, 0.05), 0.065),  # joint-2 housing
              ((0, 0, 0), (0, -0.21, 0), 0.06)),  # upper arm
    "link3": (((0, 0, -0.14), (0, 0, -0.02), 0.06),  # upper arm, elbow side
              ((0.0825, -0.05, 0), (0.0825, 0.05, 0), 0.055)),  # elbow, along joint 4
    "link4": (((0, 0, -0.05), (0, 0, 0.05), 0.06),  # elbow housing
              ((-0.0825, 0.08, 0), (-0.0825, 0.13, 0), 0.06)),  # forearm root
    "link5": (((0, 0, -0.29), (0, 0, -0.20), 0.06),  # forearm
              ((0, 0.08, -0.18), (0, 0.08, -0.05), 0.03)),  # forearm strut to the wrist
    "link6": (((0, 0, -0.03), (0, 0, 0.01), 0.055),  # wrist housing (joint 6)
              ((0.02, 0, 0), (0.088, 0, 0), 0.05)),  # towards joint 7
    "link7": (((0, 0, -0.01), (0, 0, 0.07), 0.045),),  # joint-7 housing up to the flange
}
# The Hand, in the flange frame: a bar across the finger direction (the hand's y axis is the
# flange's y turned −45° about z), standing on the flange, 0.2 m long and 56 mm thick. Its
# underside is where the fingers leave the housing (their joints 58.4 mm below the flange, as
# franka_description has them), so a top grasp may close with the pads' middle at an object's
# centre; franka_description's coarse capsule, meant for self-collision margins, reaches 80 mm.
_FINGER_DIR = np.array([np.sqrt(0.5), np.sqrt(0.5), 0.0])
HAND_CAPSULES = ((tuple(-0.072 * _FINGER_DIR + [0, 0, 0.031]),
                  tuple(0.072 * _FINGER_DIR + [0, 0, 0.031]), 0.028),)

# Contact filtering: each arm body gets its own contype bit (bit 0 is the environment's), and
# its conaffinity omits its neighbours' bits, so adjacent links (whose envelopes overlap at the
# joint by design) never collide, while every link still touches the environment.
COLLISION_BODIES = ("link0", "link1", "link2", "link3", "link4", "link5", "link6", "link7",
                    HAND_BODY)
_NO_CONTACT = {frozenset((a, b)) for a, b in zip(COLLISION_BODIES, COLLISION_BODIES[1:])}
_NO_CONTACT.add(frozenset(("link6", HAND_BODY)))  # the hand sits over joint 7, next to link 6


# Several arms: arm i also sets bit FIRST_ARM_BIT + i in its geoms' contype and accepts every
# other arm's bit, so arms (fingers included) touch each other, whatever the links.
# (Bit len(COLLISION_BODIES) + 1 is a tool's: physics/fingers.py.)
TOOL_BIT = 1 << (len(COLLISION_BODIES) + 1)
FIRST_ARM_BIT = len(COLLISION_BODIES) + 2
MAX_ARMS = 32 - FIRST_ARM_BIT
# How a contact of the arm with the world builds up. On the robot the compliance a press meets
# is the arm's (its elastic joints, ~7000 Nm/rad each, and the joint impedance behind them), so
# a fingertip or link coming down on a table at a few cm/s loads it over tens of ms. Our joints
# are rigid and carry the rotors' inertia (8 kg along z at the EE over the table), so a contact
# as hard as the pads' stops all of it within a cycle: ~150 Nm of joint torque from 3 cm/s,
# over any collision threshold on the first contact cycle. The arm's geoms (links, Hand,
# finger knuckles and soles) therefore make a softer contact with whatever they touch (they
# outrank the world's geoms, ARM_CONTACT_PRIORITY): its impedance starts near zero and reaches
# its full value over ARM_CONTACT_WIDTH of penetration, with a reference spring of
# ARM_CONTACT_SOLREF's time constant. Pressed down on the table at 3 cm/s the force then rises
# over ~30 cycles to 20 N, and a held press sinks ~0.7 mm at 10-40 N, about what the FR3's
# joints yield under 20 N there (which the robot shows in θ, not in q).
ARM_CONTACT_PRIORITY = 2
ARM_CONTACT_SOLREF = (0.03, 1.0)
ARM_CONTACT_WIDTH = 0.001  # m
ARM_CONTACT_SOLIMP = (0.001, 0.99, ARM_CONTACT_WIDTH, 0.5, 2.0)

def collision_bits(body: str) -> tuple[int, int]:
    """(contype, conaffinity) for an arm body; environment geoms keep MuJoCo's default 1/1."""
    contype = 1 << (COLLISION_BODIES.index(body) + 1)
    conaffinity = 1
    for i, other in enumerate(COLLISION_BODIES):
        if other != body and frozenset((body, other)) not in _NO_CONTACT:
            conaffinity |= 1 << (i + 1)
    return contype, conaffinity


def arm_bits(index: int, arms: int) -> tuple[int, int]:
    """(contype, conaffinity) bits the arm `index` of `arms` adds to all its geoms: none alone."""
    if arms == 1:
        return 0, 0
    if arms > MAX_ARMS:
        raise ValueError(f"at most {MAX_ARMS} arms fit in one world's collision bits")
    every = sum(1 << (FIRST_ARM_BIT + i) for i in range(arms))
    own = 1 << (FIRST_ARM_BIT + index)
    return own, every & ~own


def quat(rotation: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).ravel())
    return quat


def _add_capsules(body: mujoco.MjsBody, capsules, offset: np.ndarray, owner: str, prefix: str,
                  extra: tuple[int, int]) -> None:
    contype, conaffinity = collision_bits(owner)
    contype, conaffinity = contype | extra[0], conaffinity | extra[1]
    for k, (start, end, radius) in enumerate(capsules):
        ends = [offset[:3, :3] @ np.asarray(p, float) + offset[:3, 3] for p in (start, end)]
        body.add_geom(name=f"{prefix}{owner}_collision{k}", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
                      fromto=np.concatenate(ends), size=[radius, 0, 0], contype=contype,
                      conaffinity=conaffinity, priority=ARM_CONTACT_PRIORITY,
                      solref=ARM_CONTACT_SOLREF, solimp=ARM_CONTACT_SOLIMP,
                      group=COLLISION_GROUP, rgba=[0.9, 0.9, 0.9, 0.5])


def set_inertial(body: mujoco.MjsBody, mass: float, com, inertia) -> None:
    inertia = np.asarray(inertia, float)
    body.explicitinertial = True
    body.mass = mass
    body.ipos = np.asarray(com, float)
    body.fullinertia = [inertia[0, 0], inertia[1, 1], inertia[2, 2],
                        inertia[0, 1], inertia[0, 2], inertia[1, 2]]


def write_inertial(model: mujoco.MjModel, body: int, mass: float, com, inertia) -> None:
    """A body's inertial rewritten in a built model: mass, CoM, inertia about it (symmetric)."""
    principal, axes = np.linalg.eigh(0.5 * (inertia + inertia.T))
    if np.linalg.det(axes) < 0:
        axes[:, 0] = -axes[:, 0]
    model.body_mass[body] = mass
    model.body_ipos[body] = np.asarray(com, float)
    model.body_inertia[body] = np.clip(principal, 0.0, None)
    mujoco.mju_mat2Quat(model.body_iquat[body], np.ascontiguousarray(axes).ravel())


def add_arm(spec: mujoco.MjSpec, desc: ArmDescription, *, prefix: str = "",
            base: tuple[float, float, float, float] | None = None, armature=ROTOR_INERTIA_FR3,
            tool: ToolMount | None = None, extra_bits: tuple[int, int] = (0, 0),
            parent: mujoco.MjsBody | None = None, look: dict | None = None) -> None:
    """The arm + Hand into `spec`, its names prefixed, its base at `base` = (x, y, z, yaw) in
    the world frame (None: the world origin; the arm's root frame is then the world's, else a
    static body named after the root link).

    Without a `tool` the Hand is one rigid body; with one, the tool builds its moving parts on
    the hand body (physics/tool.py), keeping the composite the reported Hand.
    `extra_bits` (contype, conaffinity) are OR'ed into every geom's (see arm_bits). `parent`:
    the body the arm stands on (the mobile base), `base` then in its frame; None: the world.
    `look`: visual meshes by link (physics/arm_meshes.py), in place of our own shapes.
    """
    look = look or {}
    root = spec.worldbody if parent is None else parent
    add_materials(spec, prefix)
    if base is not None:
        x, y, z, yaw = base
        root = root.add_body(name=prefix + desc.root, pos=[x, y, z],
                             quat=[np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    # One MuJoCo body per moving link; links fixed to a body ride on it as an offset.
    holders: dict[int, mujoco.MjsBody] = {0: root}
    for joint in desc.joints:
        parent = desc.frames[joint.parent]
        origin = parent.offset @ joint.origin
        body = holders[parent.body].add_body(name=prefix + joint.child, pos=origin[:3, 3],
                                             quat=quat(origin[:3, :3]))
        limits = joint.limits
        # The physical stop is the widest range the robot allows: the datasheet (soft) limits.
        lower = limits.lower if limits.soft_lower is None else min(limits.lower, limits.soft_lower)
        upper = limits.upper if limits.soft_upper is None else max(limits.upper, limits.soft_upper)
        body.add_joint(name=prefix + joint.name, type=mujoco.mjtJoint.mjJNT_HINGE,
                       axis=joint.axis, range=[lower, upper],
                       limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                       armature=armature[joint.index - 1], damping=0.0, frictionloss=0.0)
        holders[joint.index] = body

    moving_links = {joint.child for joint in desc.joints}
    joint_of = {joint.child: joint for joint in desc.joints}
    for name, frame in desc.frames.items():
        if name == desc.root:
            continue
        inertial = desc.inertials.get(name)
        if name in moving_links:
            body, offset = holders[frame.body], np.eye(4)
        elif inertial is not None:
            # A massive link fixed to a body (link0 on the base): a welded body of its own,
            # which also gives its geoms a name. On the base its inertia never moves.
            body = holders[frame.body].add_body(name=prefix + name, pos=frame.offset[:3, 3],
                                                quat=quat(frame.offset[:3, :3]))
            offset = np.eye(4)
        else:  # a massless frame (flange, accelerometers): a site
            body, offset = holders[frame.body], frame.offset
            site = FLANGE_SITE if name == FLANGE_LINK else name
            body.add_site(name=prefix + site, pos=offset[:3, 3], quat=quat(offset[:3, :3]))
        if inertial is not None:
            set_inertial(body, inertial.mass, inertial.com, inertial.inertia_in_link)
        if name in COLLISION_CAPSULES:
            _add_capsules(body, COLLISION_CAPSULES[name], offset, name, prefix, extra_bits)
            moved_by = joint_of.get(name) if name in moving_links else None
            if name in look:
                add_mesh_look(spec, body, name, look[name], prefix, pos=offset[:3, 3],
                              quat=quat(offset[:3, :3]))
            else:
                add_link_look(body, name, COLLISION_CAPSULES[name], offset, prefix,
                              None if moved_by is None else moved_by.axis)

    flange = desc.frames[FLANGE_LINK]
    hand_body = holders[flange.body].add_body(name=prefix + HAND_BODY, pos=flange.offset[:3, 3],
                                              quat=quat(flange.offset[:3, :3]))
    _add_capsules(hand_body, HAND_CAPSULES, np.eye(4), HAND_BODY, prefix, extra_bits)
    if HAND_MESH in look:
        add_mesh_look(spec, hand_body, HAND_BODY, look[HAND_MESH], prefix,
                      quat=[np.cos(HAND_YAW / 2), 0.0, 0.0, np.sin(HAND_YAW / 2)])
    else:
        add_hand_look(hand_body, prefix, HAND_BODY)
    if tool is not None:
        tool.build(spec, hand_body, prefix, extra_bits)
    else:
        set_inertial(hand_body, hand.HAND_MASS, hand.HAND_COM, hand.HAND_INERTIA)

    for name in ACCELEROMETER_TOP + ACCELEROMETER_BOTTOM:
        if name not in desc.frames:  # a description without them reports zeros
            continue
        spec.add_sensor(name=prefix + name, type=mujoco.mjtSensor.mjSENS_ACCELEROMETER,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=prefix + name)
