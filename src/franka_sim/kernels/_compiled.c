/* The cycle's fused vector loops, compiled: each function gives the bits of its numpy
 * reference in kernels/reference.py (the specification; tests/physics/test_kernels.py holds
 * the two equal). Only IEEE-exact operations (+ − × ÷ and comparisons, as numpy's ufuncs do
 * them element by element), in the reference's order, built without floating-point
 * contraction (-ffp-contract=off): no fused multiply-add may change a rounding.
 *
 * Arrays come through the buffer protocol (float64, C-contiguous); no numpy headers are needed
 * to build this. A command's fields may be unaligned (a packed record): they are read with
 * memcpy.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stddef.h>
#include <string.h>

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "doubles_within reads the wire's little-endian doubles in place"
#endif

typedef struct {
    Py_buffer view;
    double *p;
    Py_ssize_t n;
} Vec;

static int vec_take(PyObject *o, Vec *v, Py_ssize_t at_least, int writable)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, &v->view, flags) < 0)
        return -1;
    const char *f = v->view.format;
    size_t len = f ? strlen(f) : 0;
    if (v->view.itemsize != 8 || len == 0 || f[len - 1] != 'd' || (len > 1 && f[0] == '>')) {
        PyBuffer_Release(&v->view);
        PyErr_SetString(PyExc_TypeError, "a float64 array in native order is expected");
        return -1;
    }
    v->p = (double *)v->view.buf;
    v->n = v->view.len / 8;
    if (v->n < at_least) {
        PyBuffer_Release(&v->view);
        PyErr_Format(PyExc_ValueError, "an array of at least %zd values is expected", at_least);
        return -1;
    }
    return 0;
}

/* Take `count` arrays from args[first...] with the sizes and writability given; on failure
 * release what was taken. */
static int vec_take_all(PyObject *const *args, Vec *v, int count, const Py_ssize_t *sizes,
                        const char *writable)
{
    for (int i = 0; i < count; i++) {
        if (vec_take(args[i], &v[i], sizes[i], writable[i] == 'w') < 0) {
            while (--i >= 0)
                PyBuffer_Release(&v[i].view);
            return -1;
        }
    }
    return 0;
}

static void vec_release_all(Vec *v, int count)
{
    for (int i = 0; i < count; i++)
        PyBuffer_Release(&v[i].view);
}

static void read7(double *out, const Vec *v)
{
    memcpy(out, v->view.buf, 7 * sizeof(double));
}

/* np.minimum / np.maximum on two doubles as numpy gives them: a NaN wins, else the second
 * when they compare equal (so max(0.0, -0.0) is -0.0); the tests hold this on the machine. */
static inline double np_min(double a, double b) { return (a != a || a < b) ? a : b; }
static inline double np_max(double a, double b) { return (a != a || a > b) ? a : b; }

static int check_args(Py_ssize_t nargs, Py_ssize_t want, const char *name)
{
    if (nargs == want)
        return 0;
    PyErr_Format(PyExc_TypeError, "%s takes %zd arguments (%zd given)", name, want, nargs);
    return -1;
}

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

static PyObject *drive_follow(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    PyObject *arrays[4];
    if (check_args(nargs, 5, "drive_follow") < 0)
        return NULL;
    double step = PyFloat_AsDouble(args[3]);
    if (step == -1.0 && PyErr_Occurred())
        return NULL;
    arrays[0] = args[0], arrays[1] = args[1], arrays[2] = args[2], arrays[3] = args[4];
    if (vec_take_all(arrays, v, 4, sizes, "ww--") < 0)
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
static PyObject *drive_impedance(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7, 7, 7, 7, 7, 7, 7};
    Vec v[10];
    PyObject *arrays[10];
    if (check_args(nargs, 11, "drive_impedance") < 0)
        return NULL;
    double step = PyFloat_AsDouble(args[3]);
    if (step == -1.0 && PyErr_Occurred())
        return NULL;
    arrays[0] = args[0], arrays[1] = args[1], arrays[2] = args[2];
    for (int i = 4; i < 11; i++)
        arrays[i - 1] = args[i];
    if (vec_take_all(arrays, v, 10, sizes, "ww--------") < 0)
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
static PyObject *saturate_less(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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

/* -- torque_inside(tau_J_d, last, out, effort, rate_threshold, dt) ----------------------------- */
static PyObject *torque_inside(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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
static PyObject *measured_inside(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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
static PyObject *joint_position_step(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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

/* -- friction_argument(dq, phi3, half_phi2, out): out = (dq + phi3)·half_phi2 --------------- */
static PyObject *friction_argument(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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
static PyObject *friction_torque(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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

/* -- add_add_sub(out, a, b, c): out = ((out + a) + b) − c ------------------------------------ */
static PyObject *add_add_sub(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 7};
    Vec v[4];
    if (check_args(nargs, 4, "add_add_sub") < 0 || vec_take_all(args, v, 4, sizes, "w---") < 0)
        return NULL;
    double *out = v[0].p;
    for (int i = 0; i < 7; i++)
        out[i] = ((out[i] + v[1].p[i]) + v[2].p[i]) - v[3].p[i];
    vec_release_all(v, 4);
    Py_RETURN_NONE;
}

/* -- impedance_torque(K, D, q_d, dq_d, q, dq, out): out = K·(q_d − q) + D·(dq_d − dq) ---------- */
static PyObject *impedance_torque(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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
static PyObject *joint_follow(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t sizes[] = {7, 7, 7, 21};
    Vec v[4];
    PyObject *arrays[4];
    if (check_args(nargs, 5, "joint_follow") < 0)
        return NULL;
    double dt = PyFloat_AsDouble(args[3]);
    if (dt == -1.0 && PyErr_Occurred())
        return NULL;
    arrays[0] = args[0], arrays[1] = args[1], arrays[2] = args[2], arrays[3] = args[4];
    if (vec_take_all(arrays, v, 4, sizes, "---w") < 0)
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

/* -- doubles_within(record, runs, bound): every little-endian double of the runs ((byte offset,
 * count) pairs) in the record's bytes is finite and within ±bound ------------------------------ */
static PyObject *doubles_within(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
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

/* -- Readings: one arm's step readings, bound to its arrays ------------------------------------ */
enum {
    R_WORK, R_APPLIED, R_ARMATURE, R_FRICTION, R_STIFFNESS, R_Q, R_DQ, R_TIMESTEPS, R_MAT, R_POS,
    R_SENSORDATA, R_DDQ, R_TAU_J, R_THETA, R_TAU_J_THETA, R_DERIVATIVES, R_WORK_Q, R_WORK_DQ,
    R_FLANGE_MAT, R_FLANGE_POS, R_WORK_SENSORS, R_COUNT
};
static const Py_ssize_t readings_sizes[R_COUNT] = {
    1, 7, 7, 7, 7, 7, 7, 15, 9, 3, 0, 7, 7, 7, 15, 15, 7, 7, 9, 3, 0};

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    Vec v[R_COUNT];
    int taken;
    Py_ssize_t *gather;
    Py_ssize_t n_gather;
} Readings;

static void readings_dealloc(Readings *self)
{
    vec_release_all(self->v, self->taken);
    PyMem_Free(self->gather);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* readings(first, previous, out): tau_J, theta and their differences into the work array, the
 * step's values copied in, and the gather of the work array into `out` (None: no gather). */
static PyObject *readings_call(Readings *self, PyObject *const *args, size_t nargsf,
                               PyObject *kwnames)
{
    static const Py_ssize_t sizes[] = {15, 0};
    Vec v[2];
    PyObject *arrays[2];
    int gathers;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    if (kwnames && PyTuple_GET_SIZE(kwnames)) {
        PyErr_SetString(PyExc_TypeError, "readings takes no keyword arguments");
        return NULL;
    }
    if (check_args(nargs, 3, "readings") < 0)
        return NULL;
    int first = PyObject_IsTrue(args[0]);
    if (first < 0)
        return NULL;
    arrays[0] = args[1], arrays[1] = args[2];
    gathers = args[2] != Py_None;
    if (vec_take_all(arrays, v, 1 + gathers, sizes, "-w") < 0)
        return NULL;
    if (gathers && v[1].n < self->n_gather) {
        vec_release_all(v, 2);
        PyErr_SetString(PyExc_ValueError, "out is shorter than the gather");
        return NULL;
    }
    Vec *r = self->v;
    double *tau_J = r[R_TAU_J].p, *theta = r[R_THETA].p;
    const double *ddq = r[R_DDQ].p;
    for (int i = 0; i < 7; i++) {
        double t = r[R_APPLIED].p[i] - r[R_ARMATURE].p[i] * ddq[i];
        t = t + r[R_FRICTION].p[i];
        tau_J[i] = t;
        theta[i] = t / r[R_STIFFNESS].p[i] + r[R_Q].p[i];
    }
    double *derivatives = r[R_DERIVATIVES].p;
    if (first) {
        memset(derivatives, 0, 15 * sizeof(double));
    } else {
        const double *now = r[R_TAU_J_THETA].p, *before = v[0].p;
        for (int i = 0; i < 15; i++)
            derivatives[i] = (now[i] - before[i]) / r[R_TIMESTEPS].p[i];
    }
    memcpy(r[R_WORK_Q].p, r[R_Q].p, 7 * sizeof(double));
    memcpy(r[R_WORK_DQ].p, r[R_DQ].p, 7 * sizeof(double));
    memcpy(r[R_FLANGE_MAT].p, r[R_MAT].p, 9 * sizeof(double));
    memcpy(r[R_FLANGE_POS].p, r[R_POS].p, 3 * sizeof(double));
    memcpy(r[R_WORK_SENSORS].p, r[R_SENSORDATA].p, r[R_SENSORDATA].n * sizeof(double));
    if (gathers) {
        const double *work = r[R_WORK].p;
        double *out = v[1].p;
        for (Py_ssize_t i = 0; i < self->n_gather; i++)
            out[i] = work[self->gather[i]];
    }
    vec_release_all(v, 1 + gathers);
    Py_RETURN_NONE;
}

static PyTypeObject ReadingsType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "franka_sim.kernels._compiled.Readings",
    .tp_doc = "One arm's step readings over its bound arrays (kernels/reference.py Readings).",
    .tp_basicsize = sizeof(Readings),
    .tp_dealloc = (destructor)readings_dealloc,
    .tp_call = PyVectorcall_Call,
    .tp_vectorcall_offset = offsetof(Readings, vectorcall),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_VECTORCALL,
};

/* bind_readings(work, applied, armature, friction, stiffness, q, dq, timesteps, mat, pos,
 *               sensordata, ddq, tau_J, theta, tau_J_theta, derivatives, work_q, work_dq,
 *               flange_mat, flange_pos, work_sensors, gather) */
static PyObject *bind_readings(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_args(nargs, R_COUNT + 1, "bind_readings") < 0)
        return NULL;
    Readings *self = PyObject_New(Readings, &ReadingsType);
    if (self == NULL)
        return NULL;
    self->vectorcall = (vectorcallfunc)readings_call;
    self->taken = 0;
    self->gather = NULL;
    self->n_gather = 0;
    for (int i = 0; i < R_COUNT; i++) {
        int writable = i == R_WORK || i >= R_TAU_J;
        if (vec_take(args[i], &self->v[i], readings_sizes[i], writable) < 0)
            goto fail;
        self->taken++;
    }
    if (self->v[R_WORK_SENSORS].n != self->v[R_SENSORDATA].n) {
        PyErr_SetString(PyExc_ValueError, "work_sensors and sensordata differ in size");
        goto fail;
    }
    PyObject *seq = PySequence_Fast(args[R_COUNT], "gather: a sequence of indices");
    if (seq == NULL)
        goto fail;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    self->gather = PyMem_Malloc((n ? n : 1) * sizeof(Py_ssize_t));
    if (self->gather == NULL) {
        Py_DECREF(seq);
        PyErr_NoMemory();
        goto fail;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_ssize_t k = PyNumber_AsSsize_t(PySequence_Fast_GET_ITEM(seq, i), PyExc_IndexError);
        if ((k == -1 && PyErr_Occurred()) || k < 0 || k >= self->v[R_WORK].n) {
            Py_DECREF(seq);
            if (!PyErr_Occurred())
                PyErr_SetString(PyExc_IndexError, "a gather index outside the work array");
            goto fail;
        }
        self->gather[i] = k;
    }
    self->n_gather = n;
    Py_DECREF(seq);
    return (PyObject *)self;
fail:
    Py_DECREF(self);
    return NULL;
}

#define FASTCALL(name) {#name, (PyCFunction)(void (*)(void))name, METH_FASTCALL, NULL}
static PyMethodDef methods[] = {
    FASTCALL(drive_follow), FASTCALL(drive_impedance), FASTCALL(saturate_less),
    FASTCALL(torque_inside), FASTCALL(measured_inside), FASTCALL(joint_position_step),
    FASTCALL(friction_argument), FASTCALL(friction_torque), FASTCALL(add_add_sub),
    FASTCALL(impedance_torque), FASTCALL(joint_follow), FASTCALL(doubles_within),
    FASTCALL(bind_readings),
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "franka_sim.kernels._compiled",
    "The cycle's fused vector loops, compiled (see kernels/reference.py).", -1, methods,
    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__compiled(void)
{
    if (PyType_Ready(&ReadingsType) < 0)
        return NULL;
    return PyModule_Create(&module);
}
