/* Compiled twin of the filter's time update (engine/filter/predict.py `_predict_py`, with
 * engine/filter/model.py `transition_and_mean` and `step_noise`): x̂ₖ₊₁|ₖ and Pₖ₊₁|ₖ over Δt
 * (thesis 6.20a/b, 6.30–6.32; Gauss–Markov fix-error states A6) in one call.
 *
 * Every operation is the one the Python does, in its order: the sines and cosines through
 * libm (what math.sin/math.cos call), the scalar products as written, numpy's elementwise
 * adds and multiplies one by one, and every ndarray.dot through the very OpenBLAS routine
 * numpy's cblas_matrixproduct picks for it (dsyrk for Γ√q·(Γ√q)ᵀ and V Vᵀ, dgemm for
 * Φ P Φᵀ and Φ P_nb, dgemv when P_nb is one column), with numpy's arguments: row-major, the
 * same transposition flags and leading dimensions, operands that numpy would copy to C order
 * copied the same way. Built with -ffp-contract=off: no FMA is fused in here.
 *
 * Python API: _bind(addresses) once (engine.native.blas.all_addresses()); then
 * predict(x, P, c, fd, fix_cov, want_phi) -> (x, P, Φ) as new arrays, or None when the inputs
 * are of a kind this kernel does not cover (the caller then runs the Python).
 * Also the arrays of the measurement rows (engine/filter/measurements.py), copies only, no
 * BLAS: rows(zs, var), lse(x, y, C, f) and stack2(za, zb, Ra, Rb, cov, m), None likewise;
 * and estimate(x, P), a state's position, depth and horizontal VCV (engine/run/cycle.py), and
 * sym2(C), the symmetrised 2×2 fix-error VCV (engine/filter/state.py), and position(), the
 * whole estimate of a state (cycle.filter_estimate) through the TM and ellipse kernels.
 * predict's x and P and estimate's VCV come back read-only (FilterState arrays).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

#include "uvn_linalg.h"

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

#define NNAV 11  /* nav states x, y, z, v, ψ, ε, v_cx, v_cy, Δv, Δψ, Δε */
#define NW 8     /* process-noise inputs (columns of G) */
#define NMAX 32  /* largest state (nav + fix-error states) handled here; larger: Python */

static const uvn_linalg_t B = UVN_LINALG;
static const int bound = 1;
static PyObject *s_dt, *s_phi, *s_gs, *s_gs_scale, *s_v_scale, *s_d, *s_dd, *s_omdd;

/* libm through volatile pointers: the compiler may neither fold nor merge sin+cos into sincos,
 * so these are the calls math.sin/math.cos make. */
static double (*volatile uvn_sin)(double) = sin;
static double (*volatile uvn_cos)(double) = cos;

#include "uvn_numpy.h"

/* A read-only view of a float64 array of known shape (any strides; d0 or d1 < 0: any). */
typedef struct {
    Py_buffer v;
    int ok;
} view_t;

static int view_get(PyObject *obj, int ndim, Py_ssize_t d0, Py_ssize_t d1, view_t *w)
{
    w->ok = 0;
    np_fields_t *f = np_direct(obj, ndim);
    if (f != NULL) {
        /* numpy's own float64 array: its fields, as its buffer would give them (no release) */
        w->v.obj = NULL;
        w->v.buf = PyArray_BYTES(f);
        w->v.ndim = ndim;
        w->v.shape = PyArray_DIMS(f);
        w->v.strides = PyArray_STRIDES(f);
        w->v.itemsize = 8;
        w->v.format = (char *)"d";
        w->ok = 1;
    } else if (PyObject_GetBuffer(obj, &w->v, PyBUF_RECORDS_RO) < 0) {
        PyErr_Clear();
        return 0;
    } else {
        w->ok = 1;
    }
    if (w->v.ndim != ndim || w->v.itemsize != 8 || w->v.format == NULL ||
        strcmp(w->v.format, "d") != 0 || (d0 >= 0 && w->v.shape[0] != d0) ||
        (ndim == 2 && d1 >= 0 && w->v.shape[1] != d1))
        return 0;
    for (int i = 0; i < ndim; i++)
        if (w->v.strides[i] % 8 != 0 || w->v.strides[i] < 0)
            return 0;
    return 1;
}

static void view_release(view_t *w)
{
    if (w->ok)
        PyBuffer_Release(&w->v);
    w->ok = 0;
}

static inline double at2(const view_t *w, Py_ssize_t i, Py_ssize_t j)
{
    return *(const double *)((const char *)w->v.buf + i * w->v.strides[0] +
                             j * w->v.strides[1]);
}

static inline double at1(const view_t *w, Py_ssize_t i)
{
    return *(const double *)((const char *)w->v.buf + i * w->v.strides[0]);
}


/* dst[i * ld + j] = w[r0 + i, c0 + j] for i < rows, j < cols: a copy (no arithmetic), a row at
 * a time where the view's rows are contiguous. */
static void copy2(const view_t *w, Py_ssize_t r0, Py_ssize_t c0, Py_ssize_t rows, Py_ssize_t cols,
                  double *dst, Py_ssize_t ld)
{
    if (w->v.strides[1] == 8) {
        for (Py_ssize_t i = 0; i < rows; i++)
            memcpy(dst + i * ld, (const char *)w->v.buf + (r0 + i) * w->v.strides[0] + c0 * 8,
                   sizeof(double) * (size_t)cols);
        return;
    }
    for (Py_ssize_t i = 0; i < rows; i++)
        for (Py_ssize_t j = 0; j < cols; j++)
            dst[i * ld + j] = at2(w, r0 + i, c0 + j);
}

/* numpy's syrk() of cblasfuncs.c for a.dot(a.T), a r×k C-ordered: C = upper of a aᵀ, then the
 * lower triangle copied from the upper. C (r×r) is zeroed first as numpy's out buffer is. */
static void np_syrk(int64_t r, int64_t k, const double *a, double *c)
{
    memset(c, 0, sizeof(double) * (size_t)(r * r));
    B.dsyrk(UvnRowMajor, UvnUpper, UvnNoTrans, r, k, 1., a, k, 0., c, r);
    for (int64_t i = 0; i < r; i++)
        for (int64_t j = i + 1; j < r; j++)
            c[j * r + i] = c[i * r + j];
}

static PyObject *kp_bind(PyObject *self, PyObject *addresses)
{
    (void)addresses; /* the routines are this kernel's own (uvn_linalg.h): nothing to bind */
    Py_RETURN_NONE;
}

static PyObject *kp_is_bound(PyObject *self, PyObject *unused)
{
    return PyBool_FromLong(bound);
}

/* Attribute `name` of `obj` as a view of the given shape; 0 (no exception) if it is not one. */
static int attr_view(PyObject *obj, PyObject *name, int ndim, Py_ssize_t d0, Py_ssize_t d1,
                     view_t *w)
{
    PyObject *a = PyObject_GetAttr(obj, name);
    w->ok = 0;
    if (a == NULL) {
        PyErr_Clear();
        return 0;
    }
    int r = view_get(a, ndim, d0, d1, w);
    Py_DECREF(a);  /* the buffer holds its own reference to the exporter */
    return r;
}

#define NVIEWS 10

static PyObject *kp_position(PyObject *self, PyObject *const *args, Py_ssize_t nargs);
static PyObject *s_t = NULL, *s_x = NULL, *s_P = NULL;

/* state._with_frozen(t, x, P) as engine/filter/predict.py's predict_step writes it inline: a
 * bare cls instance (object.__new__(cls)) whose instance dict is a copy of state's (the same
 * keys in the same order) with t, x and P replaced. NULL (exception set). */
static PyObject *frozen_state(PyObject *state, PyObject *cls, PyObject *t, PyObject *x,
                              PyObject *P)
{
    if (!PyType_Check(cls)) {
        PyErr_SetString(PyExc_TypeError, "predict: cls must be a class");
        return NULL;
    }
    if ((s_t == NULL && (s_t = PyUnicode_InternFromString("t")) == NULL) ||
        (s_x == NULL && (s_x = PyUnicode_InternFromString("x")) == NULL) ||
        (s_P == NULL && (s_P = PyUnicode_InternFromString("P")) == NULL))
        return NULL;
    PyObject *empty = PyTuple_New(0), *newst = NULL, *src = NULL, *dst = NULL;
    if (empty == NULL)
        return NULL;
    if ((newst = PyBaseObject_Type.tp_new((PyTypeObject *)cls, empty, NULL)) == NULL ||
        (src = PyObject_GenericGetDict(state, NULL)) == NULL ||
        (dst = PyDict_Copy(src)) == NULL || PyDict_SetItem(dst, s_t, t) < 0 ||
        PyDict_SetItem(dst, s_x, x) < 0 || PyDict_SetItem(dst, s_P, P) < 0 ||
        uvn_set_attrs(newst, dst) < 0)
        Py_CLEAR(newst);
    Py_DECREF(empty);
    Py_XDECREF(src);
    Py_XDECREF(dst);
    return newst;
}

static PyObject *kp_predict(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6 && nargs != 9 && nargs != 11) {
        PyErr_SetString(PyExc_TypeError,
                        "predict(x, P, c, fd, fix_cov, want_phi[, state, cls, t[, source, "
                        "packed]])");
        return NULL;
    }
    if (!bound) {
        PyErr_SetString(PyExc_RuntimeError, "kalman_predict: _bind() not called");
        return NULL;
    }
    PyObject *xo = args[0], *Po = args[1], *c = args[2], *fd = args[3], *fco = args[4];
    int want_phi = PyObject_IsTrue(args[5]);
    if (want_phi < 0)
        return NULL;
    view_t w[NVIEWS];
    for (int i = 0; i < NVIEWS; i++)
        w[i].ok = 0;
    view_t *vx = &w[0], *vP = &w[1], *vcphi = &w[2], *vgs = &w[3], *vgss = &w[4],
           *vvs = &w[5], *vfc = &w[6], *vd = &w[7], *vdd = &w[8], *vomdd = &w[9];
    PyObject *result = NULL, *xa = NULL, *Pa = NULL, *Phia = NULL;

    /* ---- inputs; anything unexpected: None (the Python path runs) ---- */
    Py_ssize_t n;
    np_fields_t *fx = np_direct(xo, 1);
    if (fx != NULL) {  /* numpy's own float64 array: its length, as its buffer would give it */
        n = PyArray_DIMS(fx)[0];
    } else {
        Py_buffer xb;
        if (PyObject_GetBuffer(xo, &xb, PyBUF_RECORDS_RO) < 0) {
            PyErr_Clear();
            Py_RETURN_NONE;
        }
        n = xb.ndim == 1 ? xb.shape[0] : -1;
        PyBuffer_Release(&xb);
    }
    int m = (int)(n - NNAV);
    int aug = fd != Py_None;
    if (n < NNAV || n > NMAX || (aug ? m < 1 : m != 0))
        goto unsupported;
    if (!view_get(xo, 1, n, 0, vx) || !view_get(Po, 2, n, n, vP) ||
        !attr_view(c, s_phi, 2, NNAV, NNAV, vcphi) || !attr_view(c, s_gs, 2, NNAV, NW, vgs) ||
        !attr_view(c, s_gs_scale, 1, NW, 0, vgss))
        goto unsupported;
    PyObject *vso = PyObject_GetAttr(c, s_v_scale);
    if (vso == NULL)
        goto fail;
    int vanloan = vso != Py_None;
    int okv = !vanloan || view_get(vso, 1, NW, 0, vvs);
    Py_DECREF(vso);
    if (!okv)
        goto unsupported;
    PyObject *dto = PyObject_GetAttr(c, s_dt);
    if (dto == NULL)
        goto fail;
    double dt = PyFloat_AsDouble(dto);
    int dt_float = PyFloat_CheckExact(dto);
    Py_DECREF(dto);
    if (!dt_float)
        goto unsupported;
    if (aug && (!view_get(fco, 2, m, m, vfc) || !attr_view(fd, s_d, 1, m, 0, vd) ||
                !attr_view(fd, s_dd, 2, m, m, vdd) || !attr_view(fd, s_omdd, 2, m, m, vomdd)))
        goto unsupported;

    /* ---- transition_and_mean: Φ_nav (6.31) and the mean (6.30) ---- */
    double xs[NMAX];
    for (Py_ssize_t i = 0; i < n; i++)
        xs[i] = at1(vx, i);
    double Phi[NNAV * NNAV];
    copy2(vcphi, 0, 0, NNAV, NNAV, Phi, NNAV);
    double v = xs[3], psi = xs[4], eps = xs[5];
    double ce = uvn_cos(eps), se = uvn_sin(eps), cp = uvn_cos(psi), sp = uvn_sin(psi);
    double vdt = v * dt;
    Phi[0 * NNAV + 3] = ce * sp * dt;
    Phi[0 * NNAV + 4] = vdt * ce * cp;
    Phi[0 * NNAV + 5] = -vdt * se * sp;
    Phi[1 * NNAV + 3] = ce * cp * dt;
    Phi[1 * NNAV + 4] = -vdt * ce * sp;
    Phi[1 * NNAV + 5] = -vdt * se * cp;
    Phi[2 * NNAV + 3] = se * dt;
    Phi[2 * NNAV + 5] = vdt * ce;
    double vc = v * ce;
    xs[0] = xs[0] + (vc * sp + xs[6]) * dt;
    xs[1] = xs[1] + (vc * cp + xs[7]) * dt;
    xs[2] = xs[2] + v * se * dt;

    /* ---- step_noise: Q_d = Gs Gsᵀ (+ V Vᵀ on the 3×3 position block) ---- */
    double Gs[NNAV * NW], Qd[NNAV * NNAV];
    copy2(vgs, 0, 0, NNAV, NW, Gs, NW);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < NW; j++)
            Gs[i * NW + j] = Phi[i * NNAV + 3 + j] * at1(vgss, j);
    np_syrk(NNAV, NW, Gs, Qd);
    if (vanloan) {
        double V[3 * NW], VV[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < NW; j++)
                V[i * NW + j] = Phi[i * NNAV + 3 + j] * at1(vvs, j);
        np_syrk(3, NW, V, VV);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                Qd[i * NNAV + j] = Qd[i * NNAV + j] + VV[i * 3 + j];
    }

    /* ---- P: Φ P Φᵀ + Q_d (nav), Φ P_nb D, D P_bb D + C (1 − D D) ---- */
    double Pn[NMAX * NMAX], T[NNAV * NNAV], U[NNAV * NNAV], Pnn[NNAV * NNAV];
    const double *Pnav;
    int transP = UvnNoTrans;
    if (!aug) {
        /* Phi.dot(P): P as numpy passes it (C order: NoTrans; Fortran order: Trans; else a
         * C-ordered copy) */
        Py_ssize_t s0 = vP->v.strides[0], s1 = vP->v.strides[1];
        if (s1 == 8 && s0 == 8 * NNAV)
            Pnav = (const double *)vP->v.buf;
        else if (s0 == 8 && s1 == 8 * NNAV) {
            Pnav = (const double *)vP->v.buf;
            transP = UvnTrans;
        } else {
            copy2(vP, 0, 0, NNAV, NNAV, Pnn, NNAV);
            Pnav = Pnn;
        }
    } else {  /* P[:11, :11] is never contiguous: numpy copies it to C order */
        copy2(vP, 0, 0, NNAV, NNAV, Pnn, NNAV);
        Pnav = Pnn;
    }
    memset(T, 0, sizeof T);
    B.dgemm(UvnRowMajor, UvnNoTrans, transP, NNAV, NNAV, NNAV, 1., Phi, NNAV, Pnav, NNAV, 0.,
            T, NNAV);
    memset(U, 0, sizeof U);
    B.dgemm(UvnRowMajor, UvnNoTrans, UvnTrans, NNAV, NNAV, NNAV, 1., T, NNAV, Phi, NNAV, 0.,
            U, NNAV);
    for (int i = 0; i < NNAV; i++)
        for (int j = 0; j < NNAV; j++)
            Pn[i * n + j] = U[i * NNAV + j] + Qd[i * NNAV + j];
    if (aug) {
        double Bn[NNAV * NMAX], W[NNAV * NMAX];
        memset(W, 0, sizeof(double) * NNAV * (size_t)m);
        if (m == 1) {
            /* Phi.dot(P[:11, 11:]) with an 11×1 column: numpy's gemv, x strided by n */
            B.dgemv(UvnRowMajor, UvnNoTrans, NNAV, NNAV, 1., Phi, NNAV,
                    (const double *)((const char *)vP->v.buf + NNAV * vP->v.strides[1]),
                    vP->v.strides[0] / 8, 0., W, 1);
        } else {  /* P[:11, 11:] is never contiguous: copied to C order, then dgemm */
            copy2(vP, 0, NNAV, NNAV, m, Bn, m);
            B.dgemm(UvnRowMajor, UvnNoTrans, UvnNoTrans, NNAV, m, NNAV, 1., Phi, NNAV, Bn, m,
                    0., W, m);
        }
        for (int i = 0; i < NNAV; i++)
            for (int j = 0; j < m; j++) {
                double e = W[i * m + j] * at1(vd, j);
                Pn[i * n + NNAV + j] = e;
                Pn[(NNAV + j) * n + i] = e;
            }
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++) {
                double p = at2(vP, NNAV + i, NNAV + j) * at2(vdd, i, j);
                Pn[(NNAV + i) * n + NNAV + j] = p + at2(vfc, i, j) * at2(vomdd, i, j);
            }
        for (int i = 0; i < m; i++)
            xs[NNAV + i] = xs[NNAV + i] * at1(vd, i);
    }

    /* ---- outputs: x, symmetrised P ((P + Pᵀ)·0.5), Φ (the full n×n if asked) ---- */
    double *xd, *Pd, *Phid;
    xa = new_array(n, 0, 1, &xd);
    if (xa == NULL)
        goto fail;
    memcpy(xd, xs, sizeof(double) * (size_t)n);
    Pa = new_array(n, n, 2, &Pd);
    if (Pa == NULL)
        goto fail;
    for (Py_ssize_t i = 0; i < n; i++)
        for (Py_ssize_t j = 0; j < n; j++)
            Pd[i * n + j] = (Pn[i * n + j] + Pn[j * n + i]) * 0.5;
    if (freeze(xa) < 0 || freeze(Pa) < 0)
        goto fail;
    if (aug && want_phi) {
        view_t vfphi;
        if (!attr_view(fd, s_phi, 2, n, n, &vfphi)) {
            view_release(&vfphi);
            goto unsupported;
        }
        Phia = new_array(n, n, 2, &Phid);
        if (Phia == NULL) {
            view_release(&vfphi);
            goto fail;
        }
        /* full = fd.phi.copy(); full[:11, :11] = Φ_nav */
        copy2(&vfphi, 0, 0, n, n, Phid, n);
        for (int i = 0; i < NNAV; i++)
            memcpy(Phid + i * n, Phi + i * NNAV, sizeof(double) * NNAV);
        view_release(&vfphi);
    } else {
        Phia = new_array(NNAV, NNAV, 2, &Phid);
        if (Phia == NULL)
            goto fail;
        memcpy(Phid, Phi, sizeof Phi);
    }
    if (nargs == 6) {
        result = PyTuple_Pack(3, xa, Pa, Phia);
        goto done;
    }
    /* (state._with_frozen(t, x, P), Φ[, position(source, packed, x, P)]) */
    {
        PyObject *newst = frozen_state(args[6], args[7], args[8], xa, Pa);
        if (newst == NULL)
            goto fail;
        if (nargs == 9) {
            result = PyTuple_Pack(2, newst, Phia);
        } else {
            PyObject *pa[4] = {args[9], args[10], xa, Pa};
            PyObject *est = kp_position(self, pa, 4);
            result = est == NULL ? NULL : PyTuple_Pack(3, newst, Phia, est);
            Py_XDECREF(est);
        }
        Py_DECREF(newst);
    }
    goto done;

unsupported:
    result = Py_NewRef(Py_None);
    goto done;
fail:
    result = NULL;
done:
    Py_XDECREF(xa);
    Py_XDECREF(Pa);
    Py_XDECREF(Phia);
    for (int i = 0; i < NVIEWS; i++)
        view_release(&w[i]);
    return result;
}

/* ---- measurement rows (engine/filter/measurements.py): arrays built by copies only ---- */

/* rows(zs, var) -> (z, R): z = np.array(zs, dtype=float), R = p×p zeros with var on the
 * diagonal (sensor_measurement), or None unless both are lists of p >= 1 exact floats. */
static PyObject *kp_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "rows(zs, var)");
        return NULL;
    }
    PyObject *zs = args[0], *var = args[1];
    if (!PyList_CheckExact(zs) || !PyList_CheckExact(var))
        Py_RETURN_NONE;
    Py_ssize_t p = PyList_GET_SIZE(zs);
    if (p < 1 || p > NMAX || PyList_GET_SIZE(var) != p)
        Py_RETURN_NONE;
    for (Py_ssize_t i = 0; i < p; i++)
        if (!PyFloat_CheckExact(PyList_GET_ITEM(zs, i)) ||
            !PyFloat_CheckExact(PyList_GET_ITEM(var, i)))
            Py_RETURN_NONE;
    double *zd, *Rd;
    PyObject *z = new_array(p, 0, 1, &zd);
    if (z == NULL)
        return NULL;
    PyObject *R = new_array(p, p, 2, &Rd);
    if (R == NULL) {
        Py_DECREF(z);
        return NULL;
    }
    memset(Rd, 0, sizeof(double) * (size_t)(p * p));
    for (Py_ssize_t i = 0; i < p; i++) {
        zd[i] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(zs, i));
        Rd[i * p + i] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(var, i));
    }
    PyObject *r = PyTuple_Pack(2, z, R);
    Py_DECREF(z);
    Py_DECREF(R);
    return r;
}

/* stack2(za, zb, Ra, Rb, cov, m) -> (z, R, prior): z = concatenate([za, zb]), R = blockdiag(Ra,
 * Rb), prior = np.array(cov[:m, :m], dtype=float) (None if cov is None) — stack_measurements
 * of two blocks; None unless all are float64 of the right shapes and cov is C-ordered. */
static PyObject *kp_stack2(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "stack2(za, zb, Ra, Rb, cov, m)");
        return NULL;
    }
    Py_ssize_t m = PyLong_AsSsize_t(args[5]);
    if (m == -1 && PyErr_Occurred())
        return NULL;
    view_t w[5];
    for (int i = 0; i < 5; i++)
        w[i].ok = 0;
    PyObject *result = NULL, *z = NULL, *R = NULL, *C = NULL;
    Py_buffer zb;
    Py_ssize_t ka, kb;
    if (PyObject_GetBuffer(args[0], &zb, PyBUF_RECORDS_RO) < 0)
        goto unsupported_clear;
    ka = zb.ndim == 1 ? zb.shape[0] : -1;
    PyBuffer_Release(&zb);
    if (PyObject_GetBuffer(args[1], &zb, PyBUF_RECORDS_RO) < 0)
        goto unsupported_clear;
    kb = zb.ndim == 1 ? zb.shape[0] : -1;
    PyBuffer_Release(&zb);
    if (ka < 1 || kb < 1 || ka + kb > 4 * NMAX)
        goto unsupported;
    if (!view_get(args[0], 1, ka, 0, &w[0]) || !view_get(args[1], 1, kb, 0, &w[1]) ||
        !view_get(args[2], 2, ka, ka, &w[2]) || !view_get(args[3], 2, kb, kb, &w[3]))
        goto unsupported;
    int with_cov = args[4] != Py_None;
    if (with_cov) {
        if (PyObject_GetBuffer(args[4], &zb, PyBUF_RECORDS_RO) < 0)
            goto unsupported_clear;
        int ok = zb.ndim == 2 && zb.shape[0] >= m && zb.shape[1] >= m && m >= 1;
        Py_ssize_t c0 = ok ? zb.shape[0] : 0, c1 = ok ? zb.shape[1] : 0;
        PyBuffer_Release(&zb);
        if (!ok || !view_get(args[4], 2, c0, c1, &w[4]) || w[4].v.strides[1] != 8 ||
            w[4].v.strides[0] != 8 * c1)
            goto unsupported;
    }
    Py_ssize_t p = ka + kb;
    double *zd, *Rd, *Cd;
    if ((z = new_array(p, 0, 1, &zd)) == NULL || (R = new_array(p, p, 2, &Rd)) == NULL)
        goto done;
    for (Py_ssize_t i = 0; i < ka; i++)
        zd[i] = at1(&w[0], i);
    for (Py_ssize_t i = 0; i < kb; i++)
        zd[ka + i] = at1(&w[1], i);
    memset(Rd, 0, sizeof(double) * (size_t)(p * p));
    for (Py_ssize_t i = 0; i < ka; i++)
        for (Py_ssize_t j = 0; j < ka; j++)
            Rd[i * p + j] = at2(&w[2], i, j);
    for (Py_ssize_t i = 0; i < kb; i++)
        for (Py_ssize_t j = 0; j < kb; j++)
            Rd[(ka + i) * p + ka + j] = at2(&w[3], i, j);
    if (with_cov) {
        if ((C = new_array(m, m, 2, &Cd)) == NULL)
            goto done;
        for (Py_ssize_t i = 0; i < m; i++)
            for (Py_ssize_t j = 0; j < m; j++)
                Cd[i * m + j] = at2(&w[4], i, j);
    } else {
        C = Py_NewRef(Py_None);
    }
    result = PyTuple_Pack(3, z, R, C);
    goto done;
unsupported_clear:
    PyErr_Clear();
unsupported:
    result = Py_NewRef(Py_None);
done:
    Py_XDECREF(z);
    Py_XDECREF(R);
    Py_XDECREF(C);
    for (int i = 0; i < 5; i++)
        view_release(&w[i]);
    return result;
}

/* estimate(x, P) -> (x, y, z, cov, finite): x[0], x[1], x[2] as floats, cov a new read-only
 * C-ordered copy of P[0:2, 0:2] and whether its four numbers are finite (the position, depth
 * and horizontal VCV of a filter state for cycle.filter_estimate), or None unless x is a
 * float64 vector of n >= 3 and P a float64 n×n array. */
static PyObject *kp_estimate(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "estimate(x, P)");
        return NULL;
    }
    view_t w[2];
    w[1].ok = 0;
    PyObject *result = NULL, *C = NULL;
    if (!view_get(args[0], 1, -1, 0, &w[0]))
        goto unsupported;
    Py_ssize_t n = w[0].v.shape[0];
    if (n < 3 || !view_get(args[1], 2, n, n, &w[1]))
        goto unsupported;
    double *Cd;
    if ((C = new_array(2, 2, 2, &Cd)) == NULL)
        goto done;
    int finite = 1;
    for (Py_ssize_t i = 0; i < 2; i++)
        for (Py_ssize_t j = 0; j < 2; j++) {
            Cd[i * 2 + j] = at2(&w[1], i, j);
            finite = finite && isfinite(Cd[i * 2 + j]);
        }
    if (freeze(C) < 0)
        goto done;
    if ((result = PyTuple_New(5)) == NULL)
        goto done;
    for (int i = 0; i < 3; i++) {
        PyObject *v = PyFloat_FromDouble(at1(&w[0], i));
        if (v == NULL) {
            Py_CLEAR(result);
            goto done;
        }
        PyTuple_SET_ITEM(result, i, v);
    }
    PyTuple_SET_ITEM(result, 3, C); /* the tuple takes C's reference */
    C = NULL;
    PyTuple_SET_ITEM(result, 4, Py_NewRef(finite ? Py_True : Py_False));
    goto done;
unsupported:
    result = Py_NewRef(Py_None);
done:
    Py_XDECREF(C);
    view_release(&w[0]);
    view_release(&w[1]);
    return result;
}

/* position(source, packed, x, P) -> PositionEstimate | None: cycle.filter_estimate in one call
 * once bind_position(inverse, ellipse, cls) has given it the compiled TM inverse
 * (engine.native.tmgrid.inverse, what TMGrid.inverse calls with the grid's _packed), the
 * compiled error ellipse (engine.native.lsq.ellipse, what error_ellipse calls) and the class.
 * The steps of the Python, in its order: estimate()'s floats and read-only VCV copy, the
 * inverse of (x, y), the ellipse of the VCV when it is finite with its eigenvectors made
 * read-only, and the instance with its eight slots set as the dataclass __init__ sets them
 * (object.__setattr__). None (nothing else done) when not bound, the inputs are not float64
 * arrays of the shapes estimate() takes, or either compiled call declines: the Python runs. */
static PyObject *pos_inverse = NULL, *pos_ellipse = NULL, *pos_cls = NULL;
static PyObject *pos_names[8], *s_eigenvectors = NULL, *s_setflags = NULL;

static PyObject *kp_bind_position(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const char *names[8] = {"source", "lat_deg", "lon_deg", "x_m", "y_m", "depth_m",
                                   "cov", "ellipse"};
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "bind_position(inverse, ellipse, cls)");
        return NULL;
    }
    if (!PyType_Check(args[2])) {
        PyErr_SetString(PyExc_TypeError, "bind_position: cls must be a class");
        return NULL;
    }
    for (int i = 0; i < 8; i++)
        if (pos_names[i] == NULL && (pos_names[i] = PyUnicode_InternFromString(names[i])) == NULL)
            return NULL;
    if ((s_eigenvectors == NULL &&
         (s_eigenvectors = PyUnicode_InternFromString("eigenvectors")) == NULL) ||
        (s_setflags == NULL && (s_setflags = PyUnicode_InternFromString("setflags")) == NULL))
        return NULL;
    Py_XSETREF(pos_inverse, Py_NewRef(args[0]));
    Py_XSETREF(pos_ellipse, Py_NewRef(args[1]));
    Py_XSETREF(pos_cls, Py_NewRef(args[2]));
    Py_RETURN_NONE;
}

/* ndarray.setflags(write=False) of an array another kernel made. 0, or -1 (exception set). */
static int freeze_any(PyObject *a)
{
    np_fields_t *f = np_direct(a, 2);
    if (f != NULL) {
        PyArray_CLEARFLAGS(f, NPY_ARRAY_WRITEABLE);
        return 0;
    }
    PyObject *r = PyObject_CallMethodOneArg(a, s_setflags, Py_False);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    return 0;
}

static PyObject *kp_position(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "position(source, packed, x, P)");
        return NULL;
    }
    if (pos_cls == NULL || args[1] == Py_None)
        Py_RETURN_NONE;
    PyObject *parts = kp_estimate(self, args + 2, 2);
    if (parts == NULL || parts == Py_None)
        return parts;
    PyObject *result = NULL, *ll = NULL, *ell = NULL, *obj = NULL, *empty = NULL;
    PyObject *xy[3] = {args[1], PyTuple_GET_ITEM(parts, 0), PyTuple_GET_ITEM(parts, 1)};
    ll = PyObject_Vectorcall(pos_inverse, xy, 3, NULL);
    if (ll == NULL)
        goto done;
    if (!PyTuple_CheckExact(ll) || PyTuple_GET_SIZE(ll) != 2)
        goto unsupported;
    PyObject *cov = PyTuple_GET_ITEM(parts, 3);
    if (PyTuple_GET_ITEM(parts, 4) == Py_True) {
        ell = PyObject_Vectorcall(pos_ellipse, &cov, 1, NULL);
        if (ell == NULL)
            goto done;
        if (ell == Py_None)
            goto unsupported;
        PyObject *vecs = PyObject_GetAttr(ell, s_eigenvectors);
        if (vecs == NULL)
            goto done;
        int r = freeze_any(vecs);
        Py_DECREF(vecs);
        if (r < 0)
            goto done;
    } else {
        ell = Py_NewRef(Py_None);
    }
    if ((empty = PyTuple_New(0)) == NULL)
        goto done;
    obj = PyBaseObject_Type.tp_new((PyTypeObject *)pos_cls, empty, NULL);
    if (obj == NULL)
        goto done;
    PyObject *vals[8] = {args[0], PyTuple_GET_ITEM(ll, 0), PyTuple_GET_ITEM(ll, 1),
                         PyTuple_GET_ITEM(parts, 0), PyTuple_GET_ITEM(parts, 1),
                         PyTuple_GET_ITEM(parts, 2), cov, ell};
    for (int i = 0; i < 8; i++)
        if (PyObject_GenericSetAttr(obj, pos_names[i], vals[i]) < 0)
            goto done;
    result = obj;
    obj = NULL;
    goto done;
unsupported:
    result = Py_NewRef(Py_None);
done:
    Py_XDECREF(obj);
    Py_XDECREF(empty);
    Py_XDECREF(ell);
    Py_XDECREF(ll);
    Py_DECREF(parts);
    return result;
}

/* sym2(C) -> S: the read-only 2×2 S = (C + Cᵀ)/2 entry by entry as FilterState.with_fix_cov
 * writes it, [[0.5·(a + a), 0.5·(b + c)], [0.5·(c + b), 0.5·(d + d)]] for C = [[a, b], [c, d]];
 * None unless C is a float64 2×2 array. */
static PyObject *kp_sym2(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 1) {
        PyErr_SetString(PyExc_TypeError, "sym2(C)");
        return NULL;
    }
    view_t w;
    PyObject *S = NULL;
    if (!view_get(args[0], 2, 2, 2, &w)) {
        view_release(&w);
        Py_RETURN_NONE;
    }
    double a = at2(&w, 0, 0), b = at2(&w, 0, 1), c = at2(&w, 1, 0), d = at2(&w, 1, 1);
    view_release(&w);
    double *Sd;
    if ((S = new_array(2, 2, 2, &Sd)) == NULL)
        return NULL;
    Sd[0] = 0.5 * (a + a);
    Sd[1] = 0.5 * (b + c);
    Sd[2] = 0.5 * (c + b);
    Sd[3] = 0.5 * (d + d);
    if (freeze(S) < 0) {
        Py_DECREF(S);
        return NULL;
    }
    return S;
}

/* lse(x, y, C, f) -> (z, R, prior): z = np.array([x, y], dtype=float), R = C * (1.0 - f),
 * prior = C * f (lse_measurement, coloured); None unless x, y, f are exact floats and C a
 * C-ordered 2×2 float64 array. */
static PyObject *kp_lse(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "lse(x, y, C, f)");
        return NULL;
    }
    if (!PyFloat_CheckExact(args[0]) || !PyFloat_CheckExact(args[1]) ||
        !PyFloat_CheckExact(args[3]))
        Py_RETURN_NONE;
    view_t w;
    if (!view_get(args[2], 2, 2, 2, &w) || w.v.strides[1] != 8 || w.v.strides[0] != 16) {
        view_release(&w);
        Py_RETURN_NONE;
    }
    double f = PyFloat_AS_DOUBLE(args[3]), omf = 1.0 - f;
    double *zd, *Rd, *Cd;
    PyObject *z = NULL, *R = NULL, *C = NULL, *result = NULL;
    if ((z = new_array(2, 0, 1, &zd)) == NULL || (R = new_array(2, 2, 2, &Rd)) == NULL ||
        (C = new_array(2, 2, 2, &Cd)) == NULL)
        goto done;
    zd[0] = PyFloat_AS_DOUBLE(args[0]);
    zd[1] = PyFloat_AS_DOUBLE(args[1]);
    const double *c = (const double *)w.v.buf;
    for (int i = 0; i < 4; i++) {
        Rd[i] = c[i] * omf;
        Cd[i] = c[i] * f;
    }
    result = PyTuple_Pack(3, z, R, C);
done:
    Py_XDECREF(z);
    Py_XDECREF(R);
    Py_XDECREF(C);
    view_release(&w);
    return result;
}

static PyMethodDef methods[] = {
    UVN_PROBE_METHOD,
    {"_bind", (PyCFunction)kp_bind, METH_O,
     "_bind(ignored): kept for callers; the small-matrix routines are the kernel's own."},
    {"is_bound", (PyCFunction)kp_is_bound, METH_NOARGS, "True once _bind has been called."},
    {"predict", (PyCFunction)(void (*)(void))kp_predict, METH_FASTCALL,
     "predict(x, P, c, fd, fix_cov, want_phi[, state, cls, t[, source, packed]]) -> (x, P, Phi) "
     "or None: one time update of engine.filter.predict (c: StepConstants, fd: FixDecay or "
     "None for the nav-only state). With state, cls, t: (state._with_frozen(t, x, P) as a new "
     "cls instance, Phi); with source, packed too: (that state, Phi, position(source, packed, "
     "x, P)), the estimate None where position() declines."},
    {"rows", (PyCFunction)(void (*)(void))kp_rows, METH_FASTCALL,
     "rows(zs, var) -> (z, R) or None: the arrays of sensor_measurement's rows."},
    {"lse", (PyCFunction)(void (*)(void))kp_lse, METH_FASTCALL,
     "lse(x, y, C, f) -> (z, R, prior) or None: the arrays of a coloured LSE measurement."},
    {"sym2", (PyCFunction)(void (*)(void))kp_sym2, METH_FASTCALL,
     "sym2(C) -> (C + C.T)/2 of a float64 2x2, read-only, or None (FilterState.with_fix_cov)."},
    {"estimate", (PyCFunction)(void (*)(void))kp_estimate, METH_FASTCALL,
     "estimate(x, P) -> (x, y, z, cov, finite) or None: a filter state's position, depth and "
     "read-only horizontal VCV copy (cycle.filter_estimate)."},
    {"bind_position", (PyCFunction)(void (*)(void))kp_bind_position, METH_FASTCALL,
     "bind_position(inverse, ellipse, cls): what position() calls and builds."},
    {"position", (PyCFunction)(void (*)(void))kp_position, METH_FASTCALL,
     "position(source, packed, x, P) -> PositionEstimate or None: cycle.filter_estimate of a "
     "state on the grid whose _packed is given, in one call."},
    {"stack2", (PyCFunction)(void (*)(void))kp_stack2, METH_FASTCALL,
     "stack2(za, zb, Ra, Rb, cov, m) -> (z, R, prior) or None: two stacked blocks' arrays."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "kalman_predict",
    "Compiled time update of the filter (engine.filter.predict), same bits as the Python.", -1,
    methods,
};

PyMODINIT_FUNC PyInit_kalman_predict(void)
{
    if (np_ready() < 0)
        return NULL;
    if (!(s_dt = PyUnicode_InternFromString("dt")) ||
        !(s_phi = PyUnicode_InternFromString("phi")) ||
        !(s_gs = PyUnicode_InternFromString("gs")) ||
        !(s_gs_scale = PyUnicode_InternFromString("gs_scale")) ||
        !(s_v_scale = PyUnicode_InternFromString("v_scale")) ||
        !(s_d = PyUnicode_InternFromString("d")) ||
        !(s_dd = PyUnicode_InternFromString("dd")) ||
        !(s_omdd = PyUnicode_InternFromString("one_minus_dd")))
        return NULL;
    PyObject *mod = PyModule_Create(&module);
    if (mod == NULL)
        return NULL;
    if (PyModule_AddStringConstant(mod, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
