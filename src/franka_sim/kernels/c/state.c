/* A state's fields written from the step's arrays (kernels/reference.py narrow_into). */
#include "kernels.h"

/* Take `o` as a writable C-contiguous float32 or float64 buffer; its kind ('f' or 'd'). */
static char take_field(PyObject *o, Py_buffer *view)
{
    if (PyObject_GetBuffer(o, view, PyBUF_WRITABLE | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return 0;
    const char *f = view->format;
    size_t len = f ? strlen(f) : 0;
    char kind = len ? f[len - 1] : 0;
    if (!((kind == 'd' && view->itemsize == 8) || (kind == 'f' && view->itemsize == 4)) ||
        (len > 1 && f[0] == '>')) {
        PyBuffer_Release(view);
        PyErr_SetString(PyExc_TypeError, "a target: float32 or float64 in native order expected");
        return 0;
    }
    return kind;
}

/* -- narrow_into(targets, sources): each target (float32 or float64) = its source (float64, the
 * same number of values), rounded as numpy casts ---------------------------------------------- */
PyObject *narrow_into(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (check_args(nargs, 2, "narrow_into") < 0)
        return NULL;
    PyObject *targets = args[0], *sources = args[1];
    if (!PyTuple_Check(targets) || !PyTuple_Check(sources) ||
        PyTuple_GET_SIZE(targets) != PyTuple_GET_SIZE(sources)) {
        PyErr_SetString(PyExc_TypeError, "targets and sources: tuples of one length");
        return NULL;
    }
    for (Py_ssize_t k = 0; k < PyTuple_GET_SIZE(targets); k++) {
        Py_buffer target;
        Vec source;
        char kind = take_field(PyTuple_GET_ITEM(targets, k), &target);
        if (!kind)
            return NULL;
        if (vec_take(PyTuple_GET_ITEM(sources, k), &source, 0, 0) < 0) {
            PyBuffer_Release(&target);
            return NULL;
        }
        Py_ssize_t n = target.len / target.itemsize;
        if (n != source.n) {
            PyBuffer_Release(&target);
            PyBuffer_Release(&source.view);
            PyErr_Format(PyExc_ValueError, "a target of %zd values for a source of %zd", n,
                         source.n);
            return NULL;
        }
        if (kind == 'd') {
            memcpy(target.buf, source.p, n * sizeof(double));
        } else {
            float *out = target.buf;
            for (Py_ssize_t i = 0; i < n; i++)
                out[i] = (float)source.p[i];
        }
        PyBuffer_Release(&target);
        PyBuffer_Release(&source.view);
    }
    Py_RETURN_NONE;
}
