/* numpy arrays read and made from C through numpy's own C API (its headers, found by setup.py
 * with numpy.get_include(); numpy is a build requirement). Shared by the kernels that include
 * it (kalman_predict.c, kalman_update.c, lsq.c, decca.c, outfmt.c, runparse.c).
 *
 * numpy's API table is imported on first use (np_ready, numpy's _import_array), not when the
 * module is imported, so a kernel module loads without importing numpy. Only the documented
 * accessors are used (PyArray_BYTES, PyArray_DIMS, PyArray_STRIDES, PyArray_FLAGS,
 * PyArray_CLEARFLAGS, PyArray_SetBaseObject, PyArray_NewFromDescr); with
 * NPY_NO_DEPRECATED_API the array struct's fields are not even visible here.
 * Static functions: each kernel that includes this keeps its own copy of the state below. */
#ifndef UVN_NUMPY_H
#define UVN_NUMPY_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <numpy/arrayobject.h>

#define NP_WRITEABLE NPY_ARRAY_WRITEABLE
#define NP_C_CONTIGUOUS NPY_ARRAY_C_CONTIGUOUS
#define NP_ALIGNED NPY_ARRAY_ALIGNED

typedef PyArrayObject np_fields_t; /* an array, read through numpy's accessors only */

static PyObject *np_ndarray = NULL; /* numpy.ndarray (&PyArray_Type) */
static PyObject *np_f64 = NULL;     /* the float64 descriptor (PyArray_DescrFromType) */
static int np_layout = -1;          /* 1: numpy's C API imported, -1: not yet */

/* A PyArray_NewFromDescr with the signature the kernels call it by. */
static PyObject *np_new_from_descr(PyTypeObject *type, PyObject *descr, int nd,
                                   const Py_ssize_t *dims, const Py_ssize_t *strides,
                                   void *data, int flags, PyObject *obj)
{
    return PyArray_NewFromDescr(type, (PyArray_Descr *)descr, nd, (npy_intp *)dims,
                                (npy_intp *)strides, data, flags, obj);
}

/* numpy's C API imported (once): 0, or -1 (exception set). */
static int np_ready(void)
{
    if (np_layout == 1)
        return 0;
    if (_import_array() < 0) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ImportError, "numpy's C API could not be imported");
        return -1;
    }
    np_ndarray = (PyObject *)&PyArray_Type;
    np_f64 = (PyObject *)PyArray_DescrFromType(NPY_DOUBLE);
    if (np_f64 == NULL)
        return -1;
    np_layout = 1;
    return 0;
}

/* `obj` when it is an exact numpy.ndarray of native float64, aligned, with `nd` dimensions
 * (then its data, shape and strides are read through numpy's accessors); else NULL. */
static np_fields_t *np_direct(PyObject *obj, int nd)
{
    if (np_layout != 1 || !PyArray_CheckExact(obj))
        return NULL;
    PyArrayObject *a = (PyArrayObject *)obj;
    if (PyArray_NDIM(a) != nd || PyArray_TYPE(a) != NPY_DOUBLE || !PyArray_ISNOTSWAPPED(a) ||
        !PyArray_ISALIGNED(a))
        return NULL;
    return a;
}

/* A new C-ordered float64 numpy array (numpy.empty((d0,) or (d0, d1))) and its data, or NULL
 * (exception set). */
static PyObject *new_array(Py_ssize_t d0, Py_ssize_t d1, int ndim, double **data)
{
    if (np_ready() < 0)
        return NULL;
    npy_intp dims[2] = {d0, d1};
    PyObject *a = PyArray_SimpleNew(ndim, dims, NPY_DOUBLE);
    if (a == NULL)
        return NULL;
    *data = (double *)PyArray_DATA((PyArrayObject *)a);
    return a;
}

/* a.setflags(write=False) for an array new_array() made: 0 (it cannot fail). */
static int freeze(PyObject *a)
{
    PyArray_CLEARFLAGS((PyArrayObject *)a, NPY_ARRAY_WRITEABLE);
    return 0;
}

/* Every key = value of dict d set on obj as object.__setattr__ sets it (into its instance dict,
 * past a frozen class's __setattr__), in d's order: 0, or -1 (exception set). Setting the
 * attributes one by one, not replacing __dict__, is what works on every CPython (3.13 keeps
 * a new object's attributes in inline values that a replaced __dict__ does not reach). */
static int uvn_set_attrs(PyObject *obj, PyObject *d)
{
    Py_ssize_t pos = 0;
    PyObject *k, *v;
    while (PyDict_Next(d, &pos, &k, &v))
        if (PyObject_GenericSetAttr(obj, k, v) < 0)
            return -1;
    return 0;
}

/* _probe(): the first-use check engine.native runs before handing the kernel out: numpy's C
 * API imported (its ABI version accepted by numpy's import_array) and an array made, written
 * and read back through it. None, or an exception naming what failed. */
static PyObject *uvn_probe(PyObject *self, PyObject *unused)
{
    (void)self;
    (void)unused;
    double *d;
    if (np_ready() < 0)
        return NULL;
    PyObject *a = new_array(2, 3, 2, &d);
    if (a == NULL)
        return NULL;
    for (int i = 0; i < 6; i++)
        d[i] = i + 0.5;
    np_fields_t *f = np_direct(a, 2);
    int ok = f != NULL && PyArray_DIMS(f)[0] == 2 && PyArray_DIMS(f)[1] == 3 &&
             PyArray_STRIDES(f)[0] == 3 * (Py_ssize_t)sizeof(double) &&
             *(double *)(PyArray_BYTES(f) + PyArray_STRIDES(f)[0] + 2 * sizeof(double)) == 5.5;
    freeze(a);
    ok = ok && !(PyArray_FLAGS(f) & NPY_ARRAY_WRITEABLE);
    Py_DECREF(a);
    if (!ok) {
        PyErr_SetString(PyExc_RuntimeError, "numpy array made through numpy's C API reads back "
                                            "wrong");
        return NULL;
    }
    Py_RETURN_NONE;
}

#define UVN_PROBE_METHOD \
    {"_probe", uvn_probe, METH_NOARGS, "_probe(): the first-use check (numpy's C API)."}

#endif /* UVN_NUMPY_H */
