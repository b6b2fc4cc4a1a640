/* numpy arrays read and made from C without numpy's headers, shared by the kernels that
 * include it (kalman_predict.c, kalman_update.c, lsq.c, decca.c, outfmt.c). Every route here is checked against numpy itself at
 * first use (np_ready): the array object's leading fields, that clearing NP_WRITEABLE is what
 * ndarray.setflags(write=False) does, and that the _ARRAY_API capsule's slot 2 is
 * numpy.ndarray; where a check fails, the buffer protocol, numpy.empty and setflags are used.
 * Static functions: each kernel that includes this keeps its own copy of the state below. */
#ifndef UVN_NUMPY_H
#define UVN_NUMPY_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

static PyObject *np_empty = NULL; /* numpy.empty, looked up by np_ready() */

/* numpy's array object up to its flags: the leading fields of PyArrayObject_fields
 * (numpy/ndarraytypes.h), the ABI through which every compiled numpy extension reads
 * PyArray_DATA and PyArray_FLAGS. Used only once np_layout_ok() has confirmed it against
 * numpy itself; otherwise the buffer protocol and ndarray.setflags are used. */
typedef struct {
    PyObject_HEAD
    char *data;
    int nd;
    Py_ssize_t *dimensions;
    Py_ssize_t *strides;
    PyObject *base;
    PyObject *descr;
    int flags;
} np_fields_t;

#define NP_WRITEABLE 0x0400 /* NPY_ARRAY_WRITEABLE */
#define NP_C_CONTIGUOUS 0x0001 /* NPY_ARRAY_C_CONTIGUOUS */
#define NP_ALIGNED 0x0100 /* NPY_ARRAY_ALIGNED */

static PyObject *np_ndarray = NULL; /* numpy.ndarray */
static PyObject *np_f64 = NULL;     /* numpy.dtype(float): the float64 descriptor numpy shares */

/* numpy.empty, numpy.ndarray and the float64 descriptor: 0, or -1 (exception set). */
static int np_import(void)
{
    PyObject *np = PyImport_ImportModule("numpy");
    if (np == NULL)
        return -1;
    PyObject *e = PyObject_GetAttrString(np, "empty");
    PyObject *t = e == NULL ? NULL : PyObject_GetAttrString(np, "ndarray");
    PyObject *d = t == NULL ? NULL : PyObject_CallMethod(np, "dtype", "s", "float64");
    Py_DECREF(np);
    if (d == NULL) {
        Py_XDECREF(e);
        Py_XDECREF(t);
        return -1;
    }
    np_ndarray = t;
    np_f64 = d;
    np_empty = e;
    return 0;
}

static int np_layout = -1; /* 1: np_fields_t checked, 0: not numpy's, -1: not checked yet */

/* numpy's C API table (the capsule numpy._core._multiarray_umath._ARRAY_API that numpy's
 * import_array() reads; its slots are numpy's ABI): slot 0 PyArray_GetNDArrayCVersion, 2 the
 * ndarray type, 94 PyArray_NewFromDescr. Used to make arrays (what numpy.empty does, without
 * its argument parsing) only once np_api_bind() found slot 2 to be numpy.ndarray and the ABI
 * version that of numpy ≥ 1.x; else numpy.empty is called. */
typedef PyObject *(*np_new_from_descr_t)(PyTypeObject *, PyObject *, int, const Py_ssize_t *,
                                         const Py_ssize_t *, void *, int, PyObject *);
static np_new_from_descr_t np_new_from_descr = NULL;

static void np_api_bind(void)
{
    PyObject *m = PyImport_ImportModule("numpy._core._multiarray_umath");
    PyObject *c = m == NULL ? NULL : PyObject_GetAttrString(m, "_ARRAY_API");
    Py_XDECREF(m);
    if (c != NULL && PyCapsule_CheckExact(c)) {
        void **table = PyCapsule_GetPointer(c, PyCapsule_GetName(c));
        if (table != NULL && table[2] == (void *)np_ndarray && table[0] != NULL &&
            ((unsigned (*)(void))table[0])() >= 0x01000009u && table[94] != NULL)
            np_new_from_descr = (np_new_from_descr_t)table[94];
    }
    Py_XDECREF(c);
    PyErr_Clear();
}

/* Is np_fields_t the layout of numpy.empty((2, 3)) (an exact ndarray of the shared float64
 * descriptor, C-contiguous and aligned, as its buffer says), and is clearing NP_WRITEABLE what
 * ndarray.setflags(write=False) does (and makes numpy refuse a writable buffer)? 1/0, -1 on an
 * error (set). */
static int np_layout_ok(void)
{
    int ok = 0;
    PyObject *a = NULL, *b = NULL, *r = NULL, *shape = Py_BuildValue("(nn)", (Py_ssize_t)2,
                                                                     (Py_ssize_t)3);
    if (shape == NULL)
        return -1;
    a = PyObject_CallOneArg(np_empty, shape);
    b = a == NULL ? NULL : PyObject_CallOneArg(np_empty, shape);
    Py_DECREF(shape);
    if (b == NULL)
        goto error;
    Py_buffer v;
    if (PyObject_GetBuffer(a, &v, PyBUF_RECORDS) != 0) {
        PyErr_Clear();
        goto done;
    }
    np_fields_t *fa = (np_fields_t *)a, *fb = (np_fields_t *)b;
    ok = (void *)fa->data == v.buf && fa->nd == 2 && fa->dimensions[0] == 2 &&
         fa->dimensions[1] == 3 && fa->strides[0] == 24 && fa->strides[1] == 8 &&
         (fa->flags & NP_WRITEABLE) && (fa->flags & NP_C_CONTIGUOUS) &&
         (fa->flags & NP_ALIGNED) && fa->flags == fb->flags && fa->flags > 0 &&
         (PyObject *)Py_TYPE(a) == np_ndarray && fa->descr == np_f64 && v.itemsize == 8 &&
         v.format != NULL && strcmp(v.format, "d") == 0;
    PyBuffer_Release(&v);
    if (!ok)
        goto done;
    int before = fa->flags;
    if ((r = PyObject_CallMethod(a, "setflags", "O", Py_False)) == NULL)
        goto error;
    ok = fa->flags == (before & ~NP_WRITEABLE);
    fb->flags &= ~NP_WRITEABLE;
    if (ok && PyObject_GetBuffer(b, &v, PyBUF_RECORDS) == 0) {
        PyBuffer_Release(&v);
        ok = 0; /* numpy still exports b as writable: not its flag */
    }
    PyErr_Clear();
done:
    Py_XDECREF(r);
    Py_XDECREF(a);
    Py_XDECREF(b);
    return ok;
error:
    Py_XDECREF(a);
    Py_XDECREF(b);
    return -1;
}

/* The array object `obj` as np_fields_t when it is an exact numpy.ndarray of float64 (the
 * shared descriptor), aligned, with `nd` dimensions: then its data, shape and strides are read
 * from it directly, without the buffer protocol (what numpy's buffer would give); else NULL. */
static np_fields_t *np_direct(PyObject *obj, int nd)
{
    if (np_layout != 1 || (PyObject *)Py_TYPE(obj) != np_ndarray)
        return NULL;
    np_fields_t *f = (np_fields_t *)obj;
    if (f->descr != np_f64 || f->nd != nd || !(f->flags & NP_ALIGNED))
        return NULL;
    return f;
}

#define NSHAPE 64
static PyObject *shape_cache[3][NSHAPE]; /* (d0,), (d0, d0), (d0, 2) for d0 < NSHAPE */

/* A new C-ordered float64 numpy array (numpy.empty((d0,) or (d0, d1))) and its data, or NULL
 * (exception set). */
static PyObject *new_array(Py_ssize_t d0, Py_ssize_t d1, int ndim, double **data)
{
    if (np_new_from_descr != NULL && np_layout == 1) {
        Py_ssize_t dims[2] = {d0, d1};
        Py_INCREF(np_f64); /* stolen */
        PyObject *a = np_new_from_descr((PyTypeObject *)np_ndarray, np_f64, ndim, dims, NULL,
                                        NULL, 0, NULL);
        if (a == NULL)
            return NULL;
        *data = (double *)((np_fields_t *)a)->data;
        return a;
    }
    PyObject *shape;
    int kind = ndim == 1 ? 0 : d1 == d0 ? 1 : d1 == 2 ? 2 : -1;
    int cached = kind >= 0 && d0 >= 0 && d0 < NSHAPE;
    if (cached && shape_cache[kind][d0] != NULL) {
        shape = Py_NewRef(shape_cache[kind][d0]);
    } else {
        shape = ndim == 1 ? Py_BuildValue("(n)", d0) : Py_BuildValue("(nn)", d0, d1);
        if (shape == NULL)
            return NULL;
        if (cached)
            shape_cache[kind][d0] = Py_NewRef(shape);
    }
    PyObject *a = PyObject_CallOneArg(np_empty, shape);
    Py_DECREF(shape);
    if (a == NULL)
        return NULL;
    if (np_layout == 1) {
        *data = (double *)((np_fields_t *)a)->data;
        return a;
    }
    Py_buffer v;
    if (PyObject_GetBuffer(a, &v, PyBUF_CONTIG) < 0) {
        Py_DECREF(a);
        return NULL;
    }
    *data = (double *)v.buf;
    PyBuffer_Release(&v); /* the array keeps its data */
    return a;
}

/* a.setflags(write=False) for an array new_array() made: 0, or -1 (exception set). */
static int freeze(PyObject *a)
{
    if (np_layout == 1) {
        ((np_fields_t *)a)->flags &= ~NP_WRITEABLE;
        return 0;
    }
    PyObject *r = PyObject_CallMethod(a, "setflags", "O", Py_False);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    return 0;
}

/* numpy looked up and its layout checked (once): 0, or -1 (exception set). */
static int np_ready(void)
{
    if (np_empty == NULL && np_import() < 0)
        return -1;
    if (np_layout < 0) {
        if ((np_layout = np_layout_ok()) < 0)
            return -1;
        np_api_bind();
    }
    return 0;
}

#endif /* UVN_NUMPY_H */
