/* franka_sim.kernels._compiled: the cycle's fused vector loops, compiled (one module from the
 * .c files beside this header: drive.c, checks.c, readings.c, state.c, module.c). */
#ifndef FRANKA_SIM_KERNELS_H
#define FRANKA_SIM_KERNELS_H

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


typedef struct {
    Py_buffer view;
    double *p;
    Py_ssize_t n;
} Vec;

static inline int vec_take(PyObject *o, Vec *v, Py_ssize_t at_least, int writable)
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
static inline int vec_take_all(PyObject *const *args, Vec *v, int count, const Py_ssize_t *sizes,
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

static inline void vec_release_all(Vec *v, int count)
{
    for (int i = 0; i < count; i++)
        PyBuffer_Release(&v[i].view);
}

static inline void read7(double *out, const Vec *v)
{
    memcpy(out, v->view.buf, 7 * sizeof(double));
}

/* np.minimum / np.maximum on two doubles as numpy gives them: a NaN wins, else the second
 * when they compare equal (so max(0.0, -0.0) is -0.0); the tests hold this on the machine. */
static inline double np_min(double a, double b) { return (a != a || a < b) ? a : b; }
static inline double np_max(double a, double b) { return (a != a || a > b) ? a : b; }

static inline int check_args(Py_ssize_t nargs, Py_ssize_t want, const char *name)
{
    if (nargs == want)
        return 0;
    PyErr_Format(PyExc_TypeError, "%s takes %zd arguments (%zd given)", name, want, nargs);
    return -1;
}

/* A kernel's arguments whose fourth is a float (a step or dt) and every other an array: check
 * their count, read the float into *x, take the arrays as vec_take_all does. */
static inline int take_around_double(PyObject *const *args, Py_ssize_t nargs, Py_ssize_t want,
                                     const char *name, double *x, Vec *v,
                                     const Py_ssize_t *sizes, const char *writable)
{
    PyObject *arrays[16];
    if (check_args(nargs, want, name) < 0)
        return -1;
    *x = PyFloat_AsDouble(args[3]);
    if (*x == -1.0 && PyErr_Occurred())
        return -1;
    for (Py_ssize_t i = 0, j = 0; i < want; i++)
        if (i != 3)
            arrays[j++] = args[i];
    return vec_take_all(arrays, v, (int)want - 1, sizes, writable);
}

/* The kernels (METH_FASTCALL), each documented where it is defined. */
#define KERNEL(name) PyObject *name(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
KERNEL(drive_follow);
KERNEL(drive_impedance);
KERNEL(saturate_less);
KERNEL(friction_argument);
KERNEL(friction_torque);
KERNEL(add_feed_forward);
KERNEL(impedance_torque);
KERNEL(joint_follow);
KERNEL(torque_inside);
KERNEL(measured_inside);
KERNEL(joint_position_step);
KERNEL(doubles_within);
KERNEL(narrow_into);
KERNEL(bind_readings);
int readings_type_ready(void);

#endif
