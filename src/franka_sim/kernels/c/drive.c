/* The drives' law, friction around numpy's tanh, the feed-forward, tau_J_d and the joint
 * reference: kernels/reference.py gives each one's meaning. */
#include "kernels.h"

/* -- drive_follow(applied, ff, tau_ff, step, gcomp) ------------------------------------------- */
static void follow(double *ff, const double *tau_ff, double step)
{
    for (int i = 0; i < 7; i++) {
        double t = tau_ff[i] - ff[i];
        t = np_min(t, step);
        t = np_max(t, -step);
        ff[i] = ff[i] + t;
    }
}

PyObject *drive_follow(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    double step;
    if (take_around_double(args, nargs, 5, "drive_follow", &step, v, sizes, "ww--") < 0)
        return NULL;
    double tau_ff[7], *applied = v[0].p, *ff = v[1].p, *g = v[3].p;
    read7(tau_ff, &v[2]);
    follow(ff, tau_ff, step);
    for (int i = 0; i < 7; i++)
        applied[i] = ff[i] + g[i];
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- drive_impedance(applied, ff, tau_ff, step, gcomp, q_d, q, K, dq_d, dq, D) ---------------- */
PyObject *drive_impedance(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7, 7, 7, 7, 7, 7, 7};
    Vec v[10];
    double step;
    if (take_around_double(args, nargs, 11, "drive_impedance", &step, v, sizes,
                           "ww--------") < 0)
        return NULL;
    double tau_ff[7], *applied = v[0].p, *ff = v[1].p, *g = v[3].p;
    const double *q_d = v[4].p, *q = v[5].p, *K = v[6].p, *dq_d = v[7].p, *dq = v[8].p,
                 *D = v[9].p;
    read7(tau_ff, &v[2]);
    follow(ff, tau_ff, step);
    for (int i = 0; i < 7; i++) {
        double spring = K[i] * (q_d[i] - q[i]);
        double damper = (dq_d[i] - dq[i]) * D[i];
        applied[i] = ((spring + damper) + ff[i]) + g[i];
    }
    vec_release_all(v, 10);
    Py_RETURN_NONE;
}

/* -- saturate_less(applied, tau_max, tau_min, friction) ---------------------------------------- */
PyObject *saturate_less(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    if (check_args(nargs, 4, "saturate_less") < 0 || vec_take_all(args, v, 4, sizes, "w---") < 0)
        return NULL;
    double *applied = v[0].p;
    for (int i = 0; i < 7; i++) {
        double a = np_min(applied[i], v[1].p[i]);
        a = np_max(a, v[2].p[i]);
        applied[i] = a - v[3].p[i];
    }
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- friction_argument(dq, phi3, half_phi2, out): out = (dq + phi3)·half_phi2 --------------- */
PyObject *friction_argument(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    if (check_args(nargs, 4, "friction_argument") < 0 ||
        vec_take_all(args, v, 4, sizes, "---w") < 0)
        return NULL;
    double dq[7];
    read7(dq, &v[0]);
    for (int i = 0; i < 7; i++)
        v[3].p[i] = (dq[i] + v[1].p[i]) * v[2].p[i];
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- friction_torque(tanh, at_rest, half_phi1, out): out = (tanh − at_rest)·half_phi1 --------- */
PyObject *friction_torque(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    if (check_args(nargs, 4, "friction_torque") < 0 ||
        vec_take_all(args, v, 4, sizes, "---w") < 0)
        return NULL;
    for (int i = 0; i < 7; i++)
        v[3].p[i] = (v[0].p[i] - v[1].p[i]) * v[2].p[i];
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- add_feed_forward(applied, M_ddq, bias, gravity): applied = ((applied + M_ddq) + bias) − g --- */
PyObject *add_feed_forward(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    if (check_args(nargs, 4, "add_feed_forward") < 0 || vec_take_all(args, v, 4, sizes, "w---") < 0)
        return NULL;
    double *out = v[0].p;
    for (int i = 0; i < 7; i++)
        out[i] = ((out[i] + v[1].p[i]) + v[2].p[i]) - v[3].p[i];
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- impedance_torque(K, D, q_d, dq_d, q, dq, out): out = K·(q_d − q) + D·(dq_d − dq) ---------- */
PyObject *impedance_torque(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7, 7, 7};
    Vec v[6];
    Py_buffer out_view;
    if (check_args(nargs, 7, "impedance_torque") < 0)
        return NULL;
    /* out: a state field, float32 on the wire (rounded as numpy casts) or float64 */
    if (PyObject_GetBuffer(args[6], &out_view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return NULL;
    const char *f = out_view.format;
    size_t len = f ? strlen(f) : 0;
    char kind = len ? f[len - 1] : 0;
    if (!((kind == 'd' && out_view.itemsize == 8) || (kind == 'f' && out_view.itemsize == 4)) ||
        (len > 1 && f[0] == '>') || out_view.len < 7 * out_view.itemsize) {
        PyBuffer_Release(&out_view);
        PyErr_SetString(PyExc_TypeError, "out: 7 float32 or float64 in native order expected");
        return NULL;
    }
    if (vec_take_all(args, v, 6, sizes, "------") < 0) {
        PyBuffer_Release(&out_view);
        return NULL;
    }
    double in[6][7], out[7];
    for (int k = 0; k < 6; k++)
        read7(in[k], &v[k]);
    for (int i = 0; i < 7; i++)
        out[i] = in[0][i] * (in[2][i] - in[4][i]) + in[1][i] * (in[3][i] - in[5][i]);
    if (kind == 'd') {
        memcpy(out_view.buf, out, sizeof out);  /* a record's field may be unaligned */
    } else {
        float narrow[7];
        for (int i = 0; i < 7; i++)
            narrow[i] = (float)out[i];
        memcpy(out_view.buf, narrow, sizeof narrow);
    }
    vec_release_all(v, 6);
    PyBuffer_Release(&out_view);
    Py_RETURN_NONE;
}

/* -- joint_follow(q_c, q_d, dq_d, dt, out): out = [q_c, dq, (dq − dq_d)/dt], dq = (q_c − q_d)/dt */
PyObject *joint_follow(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 21};
    Vec v[4];
    double dt;
    if (take_around_double(args, nargs, 5, "joint_follow", &dt, v, sizes, "---w") < 0)
        return NULL;
    double q_c[7], *out = v[3].p;
    read7(q_c, &v[0]);
    for (int i = 0; i < 7; i++) {
        double dq = (q_c[i] - v[1].p[i]) / dt;
        out[i] = q_c[i];
        out[7 + i] = dq;
        out[14 + i] = (dq - v[2].p[i]) / dt;
    }
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}
