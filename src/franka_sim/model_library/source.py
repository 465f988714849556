"""The C source of a model library, made from an arm's description.

libfranka before 0.18 takes the arm's kinematics from the library the robot sends: for each of
its frames (joints 1–7, the flange, the end effector) the pose O_T_Ji, the Jacobian in the base
frame O_J_Ji and in the frame's own axes Ji_J_Ji, each a C function of q (the end effector's
also of F_T_EE); before 0.14 its dynamics too (M_NE, c_NE, g_NE, with the load the client
says), later from the URDF. The dynamics are the rigid bodies of the URDF's inertials, as the
client's Model is: the motors' rotor inertia is not in them. Matrices are column-major, a
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


# The dynamics libfranka 0.9–0.13 take from the library (0.14 and later: from the URDF): the
# recursive Newton-Euler algorithm in each body's frame, the load (mass, centre of mass and
# inertia about it, in the flange's frame) joined to the last body.
_DYNAMICS = r"""
typedef struct { double m, c[3], I[9]; } Body; /* I about the centre of mass, body axes */

static void with_load(const double I_load[9], double m_load, const double F_x_Cload[3],
                      Body b[7]) {
  for (int i = 0; i < 7; ++i) {
    b[i].m = MASS[i];
    memcpy(b[i].c, COM[i], sizeof b[i].c);
    memcpy(b[i].I, INERTIA[i], sizeof b[i].I);
  }
  if (m_load <= 0.0) return;
  const double *F = FLANGE;
  double cl[3], Il[9], tmp[9];
  for (int r = 0; r < 3; ++r)
    cl[r] = F[4 * r] * F_x_Cload[0] + F[4 * r + 1] * F_x_Cload[1] + F[4 * r + 2] * F_x_Cload[2]
            + F[4 * r + 3];
  for (int r = 0; r < 3; ++r) /* R I_load R^T */
    for (int k = 0; k < 3; ++k) {
      tmp[3 * r + k] = 0.0;
      for (int j = 0; j < 3; ++j) tmp[3 * r + k] += F[4 * r + j] * I_load[3 * j + k];
    }
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      Il[3 * r + k] = 0.0;
      for (int j = 0; j < 3; ++j) Il[3 * r + k] += tmp[3 * r + j] * F[4 * k + j];
    }
  Body *s = &b[6];
  double m = s->m + m_load, c[3];
  for (int r = 0; r < 3; ++r) c[r] = (s->m * s->c[r] + m_load * cl[r]) / m;
  const double *cs[2] = {s->c, cl};
  const double ms[2] = {s->m, m_load};
  double I[9];
  for (int k = 0; k < 9; ++k) I[k] = s->I[k] + Il[k];
  for (int n = 0; n < 2; ++n) { /* each part's inertia moved to the joint centre of mass */
    double d[3] = {cs[n][0] - c[0], cs[n][1] - c[1], cs[n][2] - c[2]};
    double dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) I[3 * r + k] += ms[n] * ((r == k ? dd : 0.0) - d[r] * d[k]);
  }
  s->m = m;
  memcpy(s->c, c, sizeof c);
  memcpy(s->I, I, sizeof I);
}

static void cross(const double a[3], const double b[3], double out[3]) {
  double r[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  memcpy(out, r, sizeof r);
}

static void rnea(const double q[7], const double dq[7], const double ddq[7], const double g[3],
                 const Body b[7], double tau[7]) {
  double rel[7][16], w[7][3], dw[7][3], a[7][3], f[7][3], n[7][3];
  const double base_a[3] = {-g[0], -g[1], -g[2]}, zero[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < 7; ++i) {
    double turn[16];
    rotation(AXIS[i], q[i], turn);
    mul(ORIGIN[i], turn, rel[i]);
    const double *R = rel[i], p[3] = {rel[i][3], rel[i][7], rel[i][11]};
    int parent = PARENT[i] - 1;
    const double *wp = parent < 0 ? zero : w[parent], *dwp = parent < 0 ? zero : dw[parent];
    const double *ap = parent < 0 ? base_a : a[parent];
    double t[3], u[3], v[3], wr[3], zq[3];
    for (int k = 0; k < 3; ++k) zq[k] = AXIS[i][k] * dq[i];
    for (int k = 0; k < 3; ++k) /* R^T w_p */
      wr[k] = R[k] * wp[0] + R[4 + k] * wp[1] + R[8 + k] * wp[2];
    for (int k = 0; k < 3; ++k) w[i][k] = wr[k] + zq[k];
    cross(wr, zq, t);
    for (int k = 0; k < 3; ++k)
      dw[i][k] = R[k] * dwp[0] + R[4 + k] * dwp[1] + R[8 + k] * dwp[2] + AXIS[i][k] * ddq[i]
                 + t[k];
    cross(dwp, p, t);
    cross(wp, p, u);
    cross(wp, u, v);
    for (int k = 0; k < 3; ++k) u[k] = ap[k] + t[k] + v[k];
    for (int k = 0; k < 3; ++k) a[i][k] = R[k] * u[0] + R[4 + k] * u[1] + R[8 + k] * u[2];
    /* the body's force and moment about its origin, in its frame */
    double ac[3], Iw[3], Idw[3];
    cross(dw[i], b[i].c, t);
    cross(w[i], b[i].c, u);
    cross(w[i], u, v);
    for (int k = 0; k < 3; ++k) ac[k] = a[i][k] + t[k] + v[k];
    for (int k = 0; k < 3; ++k) {
      Iw[k] = b[i].I[3 * k] * w[i][0] + b[i].I[3 * k + 1] * w[i][1] + b[i].I[3 * k + 2] * w[i][2];
      Idw[k] = b[i].I[3 * k] * dw[i][0] + b[i].I[3 * k + 1] * dw[i][1]
               + b[i].I[3 * k + 2] * dw[i][2];
    }
    cross(w[i], Iw, t);
    for (int k = 0; k < 3; ++k) f[i][k] = b[i].m * ac[k];
    cross(b[i].c, f[i], u);
    for (int k = 0; k < 3; ++k) n[i][k] = Idw[k] + t[k] + u[k];
  }
  for (int i = 6; i >= 0; --i) {
    tau[i] = n[i][0] * AXIS[i][0] + n[i][1] * AXIS[i][1] + n[i][2] * AXIS[i][2];
    int parent = PARENT[i] - 1;
    if (parent < 0) continue;
    const double *R = rel[i], p[3] = {rel[i][3], rel[i][7], rel[i][11]};
    double Rf[3], Rn[3], t[3];
    for (int k = 0; k < 3; ++k) {
      Rf[k] = R[4 * k] * f[i][0] + R[4 * k + 1] * f[i][1] + R[4 * k + 2] * f[i][2];
      Rn[k] = R[4 * k] * n[i][0] + R[4 * k + 1] * n[i][1] + R[4 * k + 2] * n[i][2];
    }
    cross(p, Rf, t);
    for (int k = 0; k < 3; ++k) {
      f[parent][k] += Rf[k];
      n[parent][k] += Rn[k] + t[k];
    }
  }
}

void M_NE(const double q[7], const double I_load[9], double m_load, const double F_x_Cload[3],
          double out[49]) {
  Body b[7];
  double e[7], column[7];
  with_load(I_load, m_load, F_x_Cload, b);
  for (int j = 0; j < 7; ++j) {
    memset(e, 0, sizeof e);
    e[j] = 1.0;
    rnea(q, ZERO_Q, e, ZERO_Q, b, column);
    memcpy(out + 7 * j, column, sizeof column);
  }
}

void c_NE(const double q[7], const double dq[7], const double I_load[9], double m_load,
          const double F_x_Cload[3], double out[7]) {
  Body b[7];
  with_load(I_load, m_load, F_x_Cload, b);
  rnea(q, dq, ZERO_Q, ZERO_Q, b, out);
}

void g_NE(const double q[7], const double g_earth[3], double m_load, const double F_x_Cload[3],
          double out[7]) {
  static const double no_inertia[9] = {0};
  Body b[7];
  with_load(no_inertia, m_load, F_x_Cload, b);
  rnea(q, ZERO_Q, ZERO_Q, g_earth, b, out);
}
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
    masses, coms, inertias = _bodies(desc)
    constants = (
        f"/* {desc.name}: made by franka-sim from its description */\n"
        f"static const int PARENT[7] = {{{', '.join(map(str, parents))}}};\n"
        "static const double ORIGIN[7][16] = {"
        + ", ".join("{" + _numbers(m) + "}" for m in origins) + "};\n"
        "static const double AXIS[7][3] = {"
        + ", ".join("{" + _numbers(j.axis) + "}" for j in desc.joints) + "};\n"
        f"static const int FLANGE_BODY = {flange.body};\n"
        f"static const double FLANGE[16] = {{{_numbers(flange.offset)}}};\n"
        f"static const double MASS[7] = {{{_numbers(masses)}}};\n"
        "static const double COM[7][3] = {"
        + ", ".join("{" + _numbers(c) + "}" for c in coms) + "};\n"
        "static const double INERTIA[7][9] = {"
        + ", ".join("{" + _numbers(i) + "}" for i in inertias) + "};\n")
    return (constants + _BODY + "".join(_frame_functions(n) for n in range(1, 9))
            + _END_EFFECTOR + _DYNAMICS)


def _bodies(desc: ArmDescription) -> tuple[list, list, list]:
    """Each moving body's mass, centre of mass and inertia about it (body axes): the inertials
    of every link fixed to it, joined."""
    masses, coms, inertias = [], [], []
    for body in range(1, 8):
        parts = []  # (mass, centre of mass, inertia about it) in the body's frame
        for name, inertial in desc.inertials.items():
            frame = desc.frames[name]
            if frame.body == body and inertial.mass > 0.0:
                R, p = frame.offset[:3, :3], frame.offset[:3, 3]
                parts.append((inertial.mass, R @ inertial.com + p,
                              R @ inertial.inertia_in_link @ R.T))
        m = sum(part[0] for part in parts)
        c = sum(part[0] * part[1] for part in parts) / m if m > 0.0 else np.zeros(3)
        inertia = np.zeros((3, 3))
        for mass, com, I in parts:
            d = com - c
            inertia += I + mass * (d @ d * np.eye(3) - np.outer(d, d))
        masses.append(m)
        coms.append(c)
        inertias.append(inertia)
    return masses, coms, inertias
