/* One arm's step readings over its bound arrays (kernels/reference.py bind_readings). */
#include "kernels.h"

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
PyObject *bind_readings(PyObject *module, PyObject *const *args, Py_ssize_t nargs)
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

int readings_type_ready(void)
{
    return PyType_Ready(&ReadingsType);
}
