/* The limit checks' proofs (the usual in-limits cycle in one call) and a command's range. */
#include "kernels.h"

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "doubles_within reads the wire's little-endian doubles in place"
#endif

/* -- torque_inside(tau_J_d, last, out, effort, rate_threshold, dt) ----------------------------- */
PyObject *torque_inside(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 14, 14, 14};
    Vec v[4];
    if (check_args(nargs, 6, "torque_inside") < 0)
        return NULL;
    double threshold = PyFloat_AsDouble(args[4]);
    if (threshold == -1.0 && PyErr_Occurred())
        return NULL;
    double dt = PyFloat_AsDouble(args[5]);
    if (dt == -1.0 && PyErr_Occurred())
        return NULL;
    if (vec_take_all(args, v, 4, sizes, "--w-") < 0)
        return NULL;
    double tau[7], *out = v[2].p;
    const double *last = v[1].p, *effort = v[3].p;
    read7(tau, &v[0]);
    int inside = 1;
    for (int i = 0; i < 14; i++) {
        double t = i < 7 ? tau[i] : -tau[i - 7];
        out[i] = t;
        double rate = (t - last[i]) / dt;
        inside &= np_max(rate - threshold, t - effort[i]) <= 0.0;
    }
    vec_release_all(v, 4);
    return PyBool_FromLong(inside);
}

/* -- measured_inside(q, dq, offsets, thresholds) ------------------------------------------------ */
PyObject *measured_inside(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 28, 28};
    Vec v[4];
    if (check_args(nargs, 4, "measured_inside") < 0 || vec_take_all(args, v, 4, sizes, "----") < 0)
        return NULL;
    const double *q = v[0].p, *dq = v[1].p, *offsets = v[2].p, *thresholds = v[3].p;
    int inside = 1;
    for (int i = 0; i < 28; i++) {
        const double *x = i < 14 ? q : dq;
        int k = i % 14;
        double s = k < 7 ? x[k] : -x[k - 7];
        inside &= (s - offsets[i]) <= thresholds[i];
    }
    vec_release_all(v, 4);
    return PyBool_FromLong(inside);
}

/* -- joint_position_step(q_c, q, v, a, s1, s2, s3, floor_limits, thresholds, out) ------------ */
PyObject *joint_position_step(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 14, 14, 14, 14, 56, 56};
    Vec v[7];
    PyObject *arrays[7];
    double s[3];
    if (check_args(nargs, 10, "joint_position_step") < 0)
        return NULL;
    for (int i = 0; i < 3; i++) {
        s[i] = PyFloat_AsDouble(args[4 + i]);
        if (s[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    arrays[0] = args[0], arrays[1] = args[1], arrays[2] = args[2], arrays[3] = args[3];
    arrays[4] = args[7], arrays[5] = args[8], arrays[6] = args[9];
    if (vec_take_all(arrays, v, 7, sizes, "------w") < 0)
        return NULL;
    double q_c[7], *out = v[6].p;
    const double *q0 = v[1].p, *v0 = v[2].p, *a0 = v[3].p, *floor = v[4].p, *thr = v[5].p;
    read7(q_c, &v[0]);
    int inside = 1;
    for (int i = 0; i < 14; i++) {
        double q = i < 7 ? q_c[i] : -q_c[i - 7];
        double vel = (q - q0[i]) / s[0];
        double acc = (vel - v0[i]) / s[1];
        double jerk = (acc - a0[i]) / s[2];
        out[i] = q, out[14 + i] = vel, out[28 + i] = acc, out[42 + i] = jerk;
        inside &= q <= thr[i];
        inside &= (vel - floor[i]) <= thr[14 + i];
        inside &= acc <= thr[28 + i];
        inside &= jerk <= thr[42 + i];
    }
    vec_release_all(v, 7);
    return PyBool_FromLong(inside);
}

/* -- doubles_within(record, runs, bound): every little-endian double of the runs ((byte offset,
 * count) pairs) in the record's bytes is finite and within ±bound ------------------------------ */
PyObject *doubles_within(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer record;
    if (check_args(nargs, 3, "doubles_within") < 0)
        return NULL;
    double bound = PyFloat_AsDouble(args[2]);
    if (bound == -1.0 && PyErr_Occurred())
        return NULL;
    if (!PyTuple_Check(args[1])) {
        PyErr_SetString(PyExc_TypeError, "runs: a tuple of (offset, count) pairs");
        return NULL;
    }
    if (PyObject_GetBuffer(args[0], &record, PyBUF_SIMPLE) < 0)
        return NULL;
    int within = 1;
    const char *bytes = record.buf;
    for (Py_ssize_t r = 0; r < PyTuple_GET_SIZE(args[1]) && within; r++) {
        PyObject *run = PyTuple_GET_ITEM(args[1], r);
        Py_ssize_t offset, count;
        if (!PyTuple_Check(run) || PyTuple_GET_SIZE(run) != 2 ||
            (offset = PyLong_AsSsize_t(PyTuple_GET_ITEM(run, 0))) < 0 ||
            (count = PyLong_AsSsize_t(PyTuple_GET_ITEM(run, 1))) < 0 ||
            offset + 8 * count > record.len) {
            PyBuffer_Release(&record);
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_ValueError, "a run outside the record");
            return NULL;
        }
        for (Py_ssize_t i = 0; i < count; i++) {
            double x;
            memcpy(&x, bytes + offset + 8 * i, sizeof x);
            if (!(x <= bound && x >= -bound)) {  /* NaN fails too */
                within = 0;
                break;
            }
        }
    }
    PyBuffer_Release(&record);
    return PyBool_FromLong(within);
}
