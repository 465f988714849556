"""The stripped torque cycle: the least a torque cycle can do on this stack.

Only the MuJoCo calls a torque cycle cannot skip, on the same scene and model as franka-sim's:
before the send, the torque with g(q) added, `mj_step2` and the new q's kinematics and flange
Jacobian; after it, the rest of `mj_step1` and g(q)'s four passes at the new q. The state gets
five fields (message_id, q, dq, tau_J, and O_T_EE filled with the flange's xmat and xpos as
MuJoCo gives them, not reordered); nothing is checked, and there are no
sensors, fingers, external torque, rates or status. `cycle.py --floor` times it in a tight loop,
`reference_responder.py --physics` serves with it: what franka-sim's features cost is the
difference between these and franka-sim's own figures.
"""

from __future__ import annotations

import mujoco
import numpy as np

from franka_sim.physics.fingers import FINGERS
from franka_sim.config import READY_POSE
from franka_sim.description.urdf import default_urdf_text, load_arm_description
from franka_sim.physics.arm_model import FLANGE_SITE
from franka_sim.physics.scene import build_model, default_scene_path
from franka_sim.protocol.codec import StateBuffer


class StrippedCycle:
    def __init__(self) -> None:
        desc = load_arm_description(default_urdf_text())
        self.m = m = build_model(desc, scene_xml=default_scene_path(), tool=FINGERS)
        self.d, self.s = mujoco.MjData(m), mujoco.MjData(m)
        d = self.d
        d.qpos[:7] = READY_POSE
        mujoco.mj_forward(m, d)
        self.flange, nv = m.site(FLANGE_SITE).id, m.nv
        self.applied, self.g = d.qfrc_applied[:7], np.zeros(nv)
        self.jacp, self.jacr = np.zeros((3, nv)), np.zeros((3, nv))
        self.finish()

    def step(self, tau_J_d) -> None:
        """Before the send: the step under the answer's torque."""
        m, d = self.m, self.d
        np.add(tau_J_d, self.g[:7], out=self.applied)
        mujoco.mj_step2(m, d)
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_jacSite(m, d, self.jacp, self.jacr, self.flange)

    def write(self, state: StateBuffer, message_id: int) -> bytes:
        """Before the send: five fields, and the state's bytes."""
        d, flange = self.d, self.flange
        state.message_id[...] = message_id
        state.q[:] = d.qpos[:7]
        state.dq[:] = d.qvel[:7]
        state.tau_J[:] = self.applied
        state.O_T_EE[:12] = d.site_xmat[flange].tolist() + d.site_xpos[flange].tolist()
        return state.pack()

    def finish(self) -> None:
        """After the send: the rest of mj_step1, and g(q) at the new q."""
        m, d, s = self.m, self.d, self.s
        mujoco.mj_step1(m, d)
        s.qpos[:] = d.qpos
        s.qvel[:] = 0.0
        mujoco.mj_kinematics(m, s)
        mujoco.mj_comPos(m, s)
        mujoco.mj_comVel(m, s)
        mujoco.mj_rne(m, s, 0, self.g)
