"""The C source of a model library, made from an arm's description.

libfranka 0.15–0.17 (protocol v9) takes the arm's kinematics from the library the robot sends
(its dynamics from the URDF): for each of its frames (joints 1–7, the flange, the end effector)
the pose O_T_Ji, the Jacobian in the base frame O_J_Ji and in the frame's own axes Ji_J_Ji,
each a C function of q (the end effector's also of F_T_EE). Matrices are column-major, a
Jacobian's rows [linear; angular]. The frames are the description's (description/
kinematics.py: each joint's link after its rotation, and the flange link), so the client's
kinematics is the physics' own; each constant is written as the shortest decimal that reads
back as the same double.
"""

from __future__ import annotations

import numpy as np

from franka_sim.description.urdf import FLANGE_LINK, ArmDescription

# One joint frame's pose (16 doubles, column-major) and the chain's frames, from q.
_BODY = r"""
#include <math.h>
#include <string.h>

static void mul(const double a[16], const double b[16], double out[16]) {
  double r[16];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      double s = 0.0;
      for (int k = 0; k < 4; ++k) s += a[4 * i + k] * b[4 * k + j];
      r[4 * i + j] = s;
    }
  memcpy(out, r, sizeof r);
}

/* 4x4 rotation by angle about a unit axis (Rodrigues), row-major. */
static void rotation(const double a[3], double angle, double out[16]) {
  double c = cos(angle), s = sin(angle), t = 1.0 - c, x = a[0], y = a[1], z = a[2];
  double r[16] = {t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0.0,
                  t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0.0,
                  t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0.0,
                  0.0, 0.0, 0.0, 1.0};
  memcpy(out, r, sizeof r);
}

/* The seven joint frames and the flange (row-major). */
static void frames(const double q[7], double T[8][16]) {
  static const double identity[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double step[16], turn[16];
  for (int i = 0; i < 7; ++i) {
    const double *parent = PARENT[i] == 0 ? identity : T[PARENT[i] - 1];
    mul(parent, ORIGIN[i], step);
    rotation(AXIS[i], q[i], turn);
    mul(step, turn, T[i]);
  }
  mul(T[FLANGE_BODY - 1], FLANGE, T[7]);
}

static void column_major(const double m[16], double out[16]) {
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[4 * c + r] = m[4 * r + c];
}

static void end_effector(const double T[8][16], const double F_T_EE[16], double out[16]) {
  double f_t_ee[16];
  column_major(F_T_EE, f_t_ee); /* (its own transpose) */
  mul(T[7], f_t_ee, out);
}

/* The Jacobian of the point and axes of frame `tip` (row-major pose) moved by joints 0..last,
   in the base frame (body = 0) or in the tip's own axes (body = 1); column-major 6x7. */
static void jacobian(const double T[8][16], const double tip[16], int last, int body,
                     double out[42]) {
  memset(out, 0, 42 * sizeof(double));
  for (int j = 0; j <= last; ++j) {
    const double *f = T[j];
    double z[3], v[3];
    for (int r = 0; r < 3; ++r)
      z[r] = f[4 * r] * AXIS[j][0] + f[4 * r + 1] * AXIS[j][1] + f[4 * r + 2] * AXIS[j][2];
    double d[3] = {tip[3] - f[3], tip[7] - f[7], tip[11] - f[11]};
    v[0] = z[1] * d[2] - z[2] * d[1];
    v[1] = z[2] * d[0] - z[0] * d[2];
    v[2] = z[0] * d[1] - z[1] * d[0];
    for (int r = 0; r < 3; ++r) {
      if (body) { /* R^T v, R^T z: the tip's columns are its axes */
        out[6 * j + r] = tip[r] * v[0] + tip[4 + r] * v[1] + tip[8 + r] * v[2];
        out[6 * j + 3 + r] = tip[r] * z[0] + tip[4 + r] * z[1] + tip[8 + r] * z[2];
      } else {
        out[6 * j + r] = v[r];
        out[6 * j + 3 + r] = z[r];
      }
    }
  }
}

static const double ZERO_Q[7] = {0, 0, 0, 0, 0, 0, 0};
"""


def _numbers(values) -> str:
    return ", ".join(repr(float(v)) if np.isfinite(v) else "0.0" for v in np.ravel(values))


def _frame_functions(n: int) -> str:
    """O_T_Jn, O_J_Jn and Ji_J_Jn for frame n (1–7: the joints, 8: the flange)."""
    last = min(n, 7) - 1  # the last joint that moves it
    q = "ZERO_Q" if n == 1 else "q"  # frame 1's Jacobians do not depend on q
    args = "double out[42]" if n == 1 else "const double q[7], double out[42]"
    return f"""
void O_T_J{n}(const double q[7], double out[16]) {{
  double T[8][16];
  frames(q, T);
  column_major(T[{n - 1}], out);
}}
void O_J_J{n}({args}) {{
  double T[8][16];
  frames({q}, T);
  jacobian(T, T[{n - 1}], {last}, 0, out);
}}
void Ji_J_J{n}({args}) {{
  double T[8][16];
  frames({q}, T);
  jacobian(T, T[{n - 1}], {last}, 1, out);
}}
"""


_END_EFFECTOR = """
void O_T_J9(const double q[7], const double F_T_EE[16], double out[16]) {
  double T[8][16], ee[16];
  frames(q, T);
  end_effector(T, F_T_EE, ee);
  column_major(ee, out);
}
void O_J_J9(const double q[7], const double F_T_EE[16], double out[42]) {
  double T[8][16], ee[16];
  frames(q, T);
  end_effector(T, F_T_EE, ee);
  jacobian(T, ee, 6, 0, out);
}
void Ji_J_J9(const double q[7], const double F_T_EE[16], double out[42]) {
  double T[8][16], ee[16];
  frames(q, T);
  end_effector(T, F_T_EE, ee);
  jacobian(T, ee, 6, 1, out);
}
"""


def c_source(desc: ArmDescription) -> str:
    """The library's whole translation unit for this arm."""
    if len(desc.joints) != 7:
        raise ValueError("a model library is made for a 7-joint arm")
    origins, parents = [], []
    for joint in desc.joints:
        parent = desc.frames[joint.parent]
        origins.append(parent.offset @ joint.origin)
        parents.append(parent.body)
    flange = desc.frames[FLANGE_LINK]
    constants = (
        f"/* {desc.name}: made by franka-sim from its description */\n"
        f"static const int PARENT[7] = {{{', '.join(map(str, parents))}}};\n"
        "static const double ORIGIN[7][16] = {"
        + ", ".join("{" + _numbers(m) + "}" for m in origins) + "};\n"
        "static const double AXIS[7][3] = {"
        + ", ".join("{" + _numbers(j.axis) + "}" for j in desc.joints) + "};\n"
        f"static const int FLANGE_BODY = {flange.body};\n"
        f"static const double FLANGE[16] = {{{_numbers(flange.offset)}}};\n")
    return (constants + _BODY + "".join(_frame_functions(n) for n in range(1, 9))
            + _END_EFFECTOR)
