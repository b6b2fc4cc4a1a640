/* Compiled twin of the least-squares fix's numeric core (engine/lsq), bit for bit.
 *
 * The entry points, each the happy path of the reference Python:
 *   adjust(rows, x, used, ...)      adjustment.gauss_newton for a model with rows(): each
 *                                   iteration's used rows gathered (adjustment._evaluate), the
 *                                   step (step_calc: W = C_l^-1, A^T W, (A^T W A)^-1 with its
 *                                   conditioning guard, G = C_x A^T W, dx = G b, x + dx), the
 *                                   axis-ratio guard and the residuals, S^2, RMS, drms and
 *                                   per-slot statistics (finish_calc: adjustment._adjustment /
 *                                   statistics.used_statistics), the Adjustment's fields as a
 *                                   dict (or where to go on);
 *   ellipse(C2)                     confidence.error_ellipse (closed form);
 *   quiet(stats, k, bound)          snooping's largest |w| and its monitor band when nothing
 *                                   is to be rejected;
 *   row(*values)                    fix.LopRow(*values) without its generated __init__ (the
 *                                   same frozen slotted instance; bound by _bind_row);
 *   lop_rows(groups, stats, ...)    fix._lop_rows' table: every row() with its tests;
 *   adjust_tested(spec, x, ...)     adjust(), then the unit-variance test, the Adjustment and
 *                                   a quiet fix's TestedAdjustment built here (fix._first_py,
 *                                   fix._tested_py);
 *   estimate(grid, ..., tested, ...) fix._at_estimate of a quiet fix of the LOPs alone: the
 *                                   point, geometry, ellipse, tail() and the FixResult;
 *   tail(sets, spans, p, ...)       fix._at_estimate's linear-range check and lop_rows() of
 *                                   the systems' readings in one call (fix._tail_py).
 * Each returns None where the Python would take a rare branch (u != 2, a singular or
 * ill-conditioned matrix, non-finite values, an untestable slot, ...): the caller then runs
 * the Python, which gives the same result or the same failure reason.
 *
 * Same operations in the same order as numpy (docs/PERFORMANCE.md): ndarray.dot goes to the
 * CBLAS routine numpy's cblas_matrixproduct picks, with its Order/Trans/ld arguments;
 * numpy.linalg.inv to numpy's LAPACK dgesv on a Fortran-order copy with an identity right-hand
 * side (numpy's umath_linalg); vector.vector to 0.0 + ddot (numpy's DOUBLE_dot); reductions of
 * two terms to (0.0 + p0) + p1; np.power / np.hypot are numpy's own ufuncs, called on the
 * statistics block's rows (np_binary: numpy's loops; for power that is SVML code on an AVX-512
 * CPU, hypot is libm's there too but goes through numpy all the same);
 * Python's float ** and math.* to libm; CPython's math.hypot (its own algorithm) is called
 * through the function object.
 */
#include "uvn_linalg.h"
#include "uvn_numpy.h" /* arrays made and read without numpy.empty and the buffer protocol */

#include <math.h>
#include <string.h>

#define MAXM 32 /* most observation slots a fix may have on this path (else Python) */

static const uvn_linalg_t B = UVN_LINALG;
static int bound = 0; /* _bind() gave the Python objects */
static PyObject *py_hypot = NULL;     /* math.hypot (CPython's vector_norm, not libm) */
static PyObject *np_power = NULL;     /* numpy.power: sigma_d (5.8b) by numpy's own loop */
static PyObject *np_hypot = NULL;     /* numpy.hypot: the external reliability's norm */
static PyObject *minus_half = NULL;   /* the float -0.5, np.power's exponent */
static PyTypeObject *sol_type = NULL; /* adjustment._Solution (a NamedTuple) */
static PyObject *ellipse_type = NULL; /* confidence.Ellipse */
static PyObject *ellipse_keys[6];

/* libm through volatile pointers: no folding of pow(x, 2) into x*x or of calls into others */
static double (*volatile vpow)(double, double) = pow;
static double (*volatile vatan2)(double, double) = atan2;
static double (*volatile vfmod)(double, double) = fmod;

/* ---------------------------------------------------------------------------------------- */
/* buffers */

typedef struct {
    Py_buffer view;
    int held;
} buf_t;

static void buf_release(buf_t *b)
{
    if (b->held) {
        PyBuffer_Release(&b->view);
        b->held = 0;
    }
}

/* A float64 buffer of ndim dims (strides allowed); 0, or -1 (no exception) if not usable. */
static int buf_get(PyObject *obj, buf_t *b, int ndim)
{
    b->held = 0;
    np_fields_t *nf = np_direct(obj, ndim); /* an exact float64 ndarray: its own fields */
    if (nf != NULL) {
        for (int i = 0; i < ndim; i++)
            if (PyArray_STRIDES(nf)[i] % 8 != 0)
                return -1;
        b->view.buf = PyArray_BYTES(nf);
        b->view.ndim = ndim;
        b->view.shape = PyArray_DIMS(nf);
        b->view.strides = PyArray_STRIDES(nf);
        b->view.itemsize = 8;
        b->view.format = NULL;
        return 0;
    }
    if (PyObject_GetBuffer(obj, &b->view, PyBUF_STRIDES | PyBUF_FORMAT) < 0) {
        PyErr_Clear();
        return -1;
    }
    b->held = 1;
    const char *f = b->view.format;
    if (b->view.ndim != ndim || b->view.itemsize != 8 || f == NULL ||
        !(strcmp(f, "d") == 0 || strcmp(f, "<d") == 0 || strcmp(f, "=d") == 0)) {
        buf_release(b);
        return -1;
    }
    for (int i = 0; i < ndim; i++)
        if (b->view.strides[i] % 8 != 0) {
            buf_release(b);
            return -1;
        }
    return 0;
}

static int buf_c_contiguous(const buf_t *b)
{
    Py_ssize_t s = 8;
    for (int i = b->view.ndim - 1; i >= 0; i--) {
        if (b->view.shape[i] > 1 && b->view.strides[i] != s)
            return 0;
        s *= b->view.shape[i];
    }
    return ((uintptr_t)b->view.buf % 8) == 0;
}

#define AT2(b, i, j)                                                                          \
    (*(const double *)((const char *)(b).view.buf + (i) * (b).view.strides[0] +                \
                       (j) * (b).view.strides[1]))
#define AT1(b, i) (*(const double *)((const char *)(b).view.buf + (i) * (b).view.strides[0]))

/* numpy.empty((rows,)) (cols < 0) or numpy.empty((rows, cols)) and its data pointer, by
 * uvn_numpy.h's new_array (numpy's PyArray_NewFromDescr where np_ready() checked it, else
 * numpy.empty). New reference or NULL (error). */
static PyObject *lsq_new(Py_ssize_t rows, Py_ssize_t cols, double **data)
{
    return cols < 0 ? new_array(rows, 0, 1, data) : new_array(rows, cols, 2, data);
}

static int need_bound(void)
{
    if (!bound) {
        PyErr_SetString(PyExc_RuntimeError, "engine.native.lsq: _bind() first");
        return -1;
    }
    return 0;
}

/* CPython's math.hypot(a, b) (new reference) */
static PyObject *call_py_hypot(double a, double b)
{
    PyObject *fa = PyFloat_FromDouble(a), *fb = PyFloat_FromDouble(b);
    PyObject *r = NULL;
    if (fa != NULL && fb != NULL) {
        PyObject *args[2] = {fa, fb};
        r = PyObject_Vectorcall(py_hypot, args, 2, NULL);
    }
    Py_XDECREF(fa);
    Py_XDECREF(fb);
    return r;
}

/* out[j] = ufunc(a, b)[j] for j < m, computed by numpy itself (`ufunc(a_arr, b_obj, out_arr)`,
 * b_obj the float -0.5 or an array of b): numpy.power runs Intel's SVML code on a CPU with
 * AVX-512, not libm's pow, and rounds differently in the last bit (np.power(q, -0.5): ~5 % of
 * random q on an AVX-512 machine); numpy.hypot is libm's there (0 of 50,000 pairs differed)
 * but goes through numpy too, so neither depends on what a numpy release dispatches to.
 * Calling numpy gives the Python twin's bits on every CPU. 0, or -1 (exception set). */
static int np_binary(PyObject *ufunc, const double *a, const double *b, Py_ssize_t m,
                     double *out)
{
    double *ad, *bd = NULL, *od;
    PyObject *ao = lsq_new(m, -1, &ad);
    PyObject *bo = ao == NULL ? NULL : b == NULL ? Py_NewRef(minus_half) : lsq_new(m, -1, &bd);
    PyObject *oo = bo == NULL ? NULL : lsq_new(m, -1, &od);
    int ret = -1;
    if (oo != NULL) {
        memcpy(ad, a, sizeof(double) * m);
        if (bd != NULL)
            memcpy(bd, b, sizeof(double) * m);
        PyObject *args[3] = {ao, bo, oo};
        PyObject *r = PyObject_Vectorcall(ufunc, args, 3, NULL);
        if (r != NULL) {
            Py_DECREF(r); /* oo itself */
            memcpy(out, od, sizeof(double) * m);
            ret = 0;
        }
    }
    Py_XDECREF(ao);
    Py_XDECREF(bo);
    Py_XDECREF(oo);
    return ret;
}

/* numpy's pairwise sum (DOUBLE_pairwise_sum, n <= 128) from 0.0: only its finiteness is used */
static double np_sum(const double *a, Py_ssize_t n)
{
    double res;
    if (n < 8) {
        res = -0.0;
        for (Py_ssize_t i = 0; i < n; i++)
            res += a[i];
    }
    else {
        double r[8];
        Py_ssize_t i;
        for (int j = 0; j < 8; j++)
            r[j] = a[j];
        for (i = 8; i < n - (n % 8); i += 8)
            for (int j = 0; j < 8; j++)
                r[j] += a[i + j];
        res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        for (; i < n; i++)
            res += a[i];
    }
    return 0.0 + res;
}

/* ---------------------------------------------------------------------------------------- */
/* step */

/* One step's numbers in C buffers (step_calc), wrapped into arrays only where the caller
 * needs them (step_solution). 64-byte alignment, as numpy's own data at least. */
typedef struct {
    Py_ssize_t m;
    _Alignas(64) double W[MAXM * MAXM];
    _Alignas(64) double atw[2 * MAXM];
    _Alignas(64) double cx[4];
    _Alignas(64) double gain[2 * MAXM];
    _Alignas(64) double dx[2];
    double xn[2], i00, i01, i11, big;
} step_t;

/* step's arithmetic on raw inputs: Au (m, 2) C-contiguous, bu (m,) contiguous, C_l's element
 * (i, j) at cl[i * cs0 + j * cs1] (strides in doubles), x = (x0, x1). 1: done, 0: declined
 * (the Python's rare branch); never an exception. */
static int step_calc(step_t *s, const double *Au, const double *bu, const double *cl,
                     Py_ssize_t cs0, Py_ssize_t cs1, Py_ssize_t m, double cond_max, double x0,
                     double x1)
{
    s->m = m;
    /* W = inv(C_l): numpy copies to Fortran order, solves with an identity right-hand side */
    double fa[MAXM * MAXM];
    int64_t ipiv[MAXM];
    double wf[MAXM * MAXM];
    for (Py_ssize_t j = 0; j < m; j++)
        for (Py_ssize_t i = 0; i < m; i++) {
            fa[i + j * m] = cl[i * cs0 + j * cs1];
            wf[i + j * m] = (i == j) ? 1.0 : 0.0;
        }
    int64_t n64 = m, info = 0;
    B.npl_dgesv(&n64, &n64, fa, &n64, ipiv, wf, &n64, &info);
    if (info != 0)
        return 0;
    double *W = s->W;
    for (Py_ssize_t i = 0; i < m; i++)
        for (Py_ssize_t j = 0; j < m; j++)
            W[i * m + j] = wf[i + j * m];

    /* atw = Au.T.dot(W): Au.T is F-contiguous (Trans, lda 2) */
    double *atw = s->atw;
    memset(atw, 0, sizeof(double) * 2 * m);
    B.dgemm(UvnRowMajor, UvnTrans, UvnNoTrans, 2, m, m, 1.0, Au, 2, W, m, 0.0, atw, m);
    /* N = atw.dot(Au) */
    double nm[4] = {0.0, 0.0, 0.0, 0.0};
    B.dgemm(UvnRowMajor, UvnNoTrans, UvnNoTrans, 2, 2, m, 1.0, atw, m, Au, 2, 0.0, nm, 2);

    /* _inv_normal, 2x2 closed form */
    double na = nm[0], nc = nm[1], nd = nm[3];
    double det = na * nd - nc * nc;
    if (!(na > 0.0 && nd > 0.0 && det > 0.0))
        return 0;
    double ad = na * nd;
    double rho = fabs(nc) / sqrt(ad);
    double i00 = nd / det, i01 = -nc / det, i11 = na / det;
    double cond = vpow(1.0 + rho, 2.0) * ad / det;
    if (!(cond <= cond_max))
        return 0;
    if (!isfinite(np_sum(bu, m)))
        return 0;
    double *cx = s->cx;
    cx[0] = i00;
    cx[1] = i01;
    cx[2] = i01;
    cx[3] = i11;
    /* gain = cx.dot(atw); dx = gain.dot(bu) (gemv) */
    double *gain = s->gain, *dx = s->dx;
    memset(gain, 0, sizeof(double) * 2 * m);
    B.dgemm(UvnRowMajor, UvnNoTrans, UvnNoTrans, 2, m, 2, 1.0, cx, 2, atw, m, 0.0, gain, m);
    dx[0] = dx[1] = 0.0;
    B.dgemv(UvnRowMajor, UvnNoTrans, 2, m, 1.0, gain, m, bu, 1, 0.0, dx, 1);
    if (!(isfinite(dx[0]) && isfinite(dx[1])))
        return 0;
    s->xn[0] = x0 + dx[0];
    s->xn[1] = x1 + dx[1];
    s->i00 = i00;
    s->i01 = i01;
    s->i11 = i11;
    double big = fabs(dx[0]);
    if (fabs(dx[1]) > big)
        big = fabs(dx[1]);
    s->big = big;
    return 1;
}

/* A new array (cols < 0: 1-D) holding a copy of src; new reference or NULL (error). */
static PyObject *array_of(Py_ssize_t rows, Py_ssize_t cols, const double *src)
{
    double *d;
    PyObject *o = lsq_new(rows, cols, &d);
    if (o != NULL)
        memcpy(d, src, sizeof(double) * rows * (cols < 0 ? 1 : cols));
    return o;
}

/* ---------------------------------------------------------------------------------------- */
/* the residuals and statistics of a solution (adjustment._adjustment) */

/* finish's results (finish_calc): new references to v (n,), the displayed C_x (cxo itself
 * unless scaled), the (9, n) statistics and S^2 (a float or None). */
typedef struct {
    PyObject *vo, *covo, *stato, *s2o;
    double s2, rms, drms;
    Py_ssize_t r;
    int scaled;
} fin_t;

/* _adjustment's arithmetic on raw inputs: Au (m, 2), bu (m,), W, atw (2, m), cx (2, 2) (its
 * array cxo), gain (2, m), dx (2,) C-contiguous, C_l's element (i, j) at cl[i * cs0 + j * cs1]
 * (strides in doubles), slot[j] the used slots among n. 1: done (f filled), 0: declined (an
 * untestable slot), -1: error (exception set). */
static int finish_calc(fin_t *f, const double *Au, const double *bu, const double *cl,
                       Py_ssize_t cs0, Py_ssize_t cs1, const double *W, const double *atw,
                       const double *cx, PyObject *cxo, const double *gain, const double *dx,
                       const Py_ssize_t *slot, Py_ssize_t m, Py_ssize_t n, int scale_vcv,
                       double d0)
{
    PyObject *vo = NULL, *covo = NULL, *stato = NULL, *s2o = NULL;
    int ret = -1;
    /* vu = Au.dot(dx) - bu (gemv); wv = W.dot(vu) (gemv) */
    double vu[MAXM], wv[MAXM];
    memset(vu, 0, sizeof(double) * m);
    memset(wv, 0, sizeof(double) * m);
    B.dgemv(UvnRowMajor, UvnNoTrans, m, 2, 1.0, Au, 2, dx, 1, 0.0, vu, 1);
    for (Py_ssize_t i = 0; i < m; i++)
        vu[i] = vu[i] - bu[i];
    B.dgemv(UvnRowMajor, UvnNoTrans, m, m, 1.0, W, m, vu, 1, 0.0, wv, 1);
    Py_ssize_t r = m - 2;
    double s2 = 0.0;
    if (r >= 1)
        s2 = (0.0 + B.ddot(m, vu, 1, wv, 1)) / (double)r; /* (5.13) */
    double rms = sqrt((0.0 + B.ddot(m, vu, 1, vu, 1)) / (double)m);
    int scaled = scale_vcv && r >= 1;
    double trace;
    if (scaled) {
        double *cov;
        covo = lsq_new(2, 2, &cov);
        if (covo == NULL)
            goto out;
        for (int i = 0; i < 4; i++)
            cov[i] = cx[i] * s2;
        trace = (0.0 + cov[0]) + cov[3];
    }
    else {
        covo = Py_NewRef(cxo);
        trace = (0.0 + cx[0]) + cx[3]; /* sum((cx2[0], cx2[2])) */
    }
    if (0.0 > trace) /* max(trace, 0.0) */
        trace = 0.0;
    double drms = sqrt(trace);

    double *st;
    stato = lsq_new(9, n, &st);
    if (stato == NULL)
        goto out;
    for (Py_ssize_t i = 0; i < 9 * n; i++)
        st[i] = NAN;
    if (r >= 1) {
        /* used_statistics (u = 2) */
        double q[MAXM], ac[2 * MAXM];
        for (Py_ssize_t j = 0; j < m; j++) {
            double wjj = W[j * m + j];
            q[j] = wjj - ((0.0 + atw[j] * gain[j]) + atw[m + j] * gain[m + j]);
            if (!(q[j] / wjj > 1e-10)) { /* an untestable slot: the Python marks it */
                ret = 0;
                goto out;
            }
        }
        memset(ac, 0, sizeof(double) * 2 * m);
        B.dgemm(UvnRowMajor, UvnNoTrans, UvnNoTrans, m, 2, 2, 1.0, Au, 2, cx, 2, 0.0, ac, 2);
        double sd[MAXM], e0[MAXM], e1[MAXM], ext[MAXM];
        if (np_binary(np_power, q, NULL, m, sd) < 0) /* np.power(q, -0.5) */
            goto out;
        for (Py_ssize_t j = 0; j < m; j++) {
            double mdb = sd[j] * d0;
            e0[j] = gain[j] * mdb;
            e1[j] = gain[m + j] * mdb;
        }
        if (np_binary(np_hypot, e0, e1, m, ext) < 0) /* np.hypot(ext[0], ext[1]) */
            goto out;
        for (Py_ssize_t j = 0; j < m; j++) {
            Py_ssize_t c = slot[j];
            double var_l = cl[j * cs0 + j * cs1];
            st[0 * n + c] = sd[j];
            st[1 * n + c] = -(wv[j] * sd[j]);
            st[2 * n + c] = sd[j] / sqrt(var_l);
            st[3 * n + c] = ((0.0 + Au[2 * j] * ac[2 * j]) + Au[2 * j + 1] * ac[2 * j + 1]) / var_l;
            st[4 * n + c] = 1.0 - ((0.0 + Au[2 * j] * gain[j]) + Au[2 * j + 1] * gain[m + j]);
            st[5 * n + c] = sd[j] * d0;
            st[6 * n + c] = ext[j];
            st[7 * n + c] = e0[j];
            st[8 * n + c] = e1[j];
        }
    }
    double *v;
    vo = lsq_new(n, -1, &v);
    if (vo == NULL)
        goto out;
    for (Py_ssize_t i = 0; i < n; i++)
        v[i] = NAN;
    for (Py_ssize_t j = 0; j < m; j++)
        v[slot[j]] = vu[j];
    if (r >= 1) {
        s2o = PyFloat_FromDouble(s2);
        if (s2o == NULL)
            goto out;
    }
    else
        s2o = Py_NewRef(Py_None);
    f->vo = vo;
    f->covo = covo;
    f->stato = stato;
    f->s2o = s2o;
    f->s2 = s2;
    f->rms = rms;
    f->drms = drms;
    f->r = r;
    f->scaled = scaled;
    return 1;
out:
    Py_XDECREF(vo);
    Py_XDECREF(covo);
    Py_XDECREF(stato);
    Py_XDECREF(s2o);
    return ret;
}

/* ---------------------------------------------------------------------------------------- */
/* adjust: gauss_newton's whole loop, axis-ratio guard and finish in one call */

PyDoc_STRVAR(adjust_doc,
"adjust(rows, x, used, eps, max_iter, cond_max, max_axis_ratio, scale_vcv, d0)\n"
"-> dict, (iterations, x, steps) or None\n"
"\n"
"engine.lsq.adjustment.gauss_newton for a model with rows() (u = 2, no damping): rows(x)\n"
"called as _iterate calls it, each step on its used rows, then _check_axis_ratio and the\n"
"residuals and statistics (_adjustment).\n"
"x (2,) float64, used (n,) bool (the arrays gauss_newton made). rows may instead be the\n"
"model's spec (fix._Model.spec: parts, Point, grid, geodesic, eye), for which adjust does what\n"
"_Model.rows does (the lists, the copy of eye, the Point, each part's linearise) itself.\n"
"Returns the Adjustment's\n"
"fields in order as a new dict (variance_test None: the caller's) when every part took the\n"
"case; None when nothing was done (m < 2 or > 32, x not finite, other shapes); else the state\n"
"(iterations done, x, the list of step lengths) after the last iteration the Python need not\n"
"run again: it goes on from there (a failure, a rare branch, an exception of rows()).");

#define N_ADJ_KEYS 26
static PyObject *adj_keys[N_ADJ_KEYS];
static PyObject *cat_names[4];
static PyObject *no_convergence = NULL;

static int adjust_ready(void)
{
    static const char *names[N_ADJ_KEYS] = {
        "ok", "reason", "x", "cov_x", "cov_x_apriori", "used", "n_used", "u", "redundancy",
        "category", "iterations", "converged", "steps", "dx", "v", "s2", "rms_m", "drms_m",
        "stats_block", "A_used", "b_used", "Cl_used", "W_used", "variance_test", "scaled",
        "damping"};
    static const char *cats[4] = {"I", "II", "III", "IV"};
    if (no_convergence != NULL)
        return 0;
    for (int i = 0; i < N_ADJ_KEYS; i++)
        if ((adj_keys[i] = PyUnicode_InternFromString(names[i])) == NULL)
            return -1;
    for (int i = 0; i < 4; i++)
        if ((cat_names[i] = PyUnicode_InternFromString(cats[i])) == NULL)
            return -1;
    no_convergence = PyUnicode_InternFromString("no convergence");
    return no_convergence == NULL ? -1 : 0;
}

/* The used rows of rows()'s result (A list of 2n floats, b list of n floats, Cl (n, n)) into
 * Au, bu, Clu (as adjustment._evaluate slices them): 1 done, 0 not this shape or type. */
static int gather(PyObject *got, Py_ssize_t n, const Py_ssize_t *slot, Py_ssize_t m,
                  double *Au, double *bu, double *Clu)
{
    if (!PyTuple_CheckExact(got) || PyTuple_GET_SIZE(got) != 3)
        return 0;
    PyObject *al = PyTuple_GET_ITEM(got, 0), *bl = PyTuple_GET_ITEM(got, 1);
    if (!PyList_CheckExact(al) || !PyList_CheckExact(bl) || PyList_GET_SIZE(bl) != n ||
        PyList_GET_SIZE(al) != 2 * n)
        return 0;
    for (Py_ssize_t j = 0; j < m; j++) {
        Py_ssize_t s = slot[j];
        PyObject *a0 = PyList_GET_ITEM(al, 2 * s), *a1 = PyList_GET_ITEM(al, 2 * s + 1);
        PyObject *b0 = PyList_GET_ITEM(bl, s);
        if (!PyFloat_CheckExact(a0) || !PyFloat_CheckExact(a1) || !PyFloat_CheckExact(b0))
            return 0;
        Au[2 * j] = PyFloat_AS_DOUBLE(a0);
        Au[2 * j + 1] = PyFloat_AS_DOUBLE(a1);
        bu[j] = PyFloat_AS_DOUBLE(b0);
    }
    buf_t cl = {0};
    if (buf_get(PyTuple_GET_ITEM(got, 2), &cl, 2) < 0)
        return 0;
    if (cl.view.shape[0] != n || cl.view.shape[1] != n) {
        buf_release(&cl);
        return 0;
    }
    for (Py_ssize_t j = 0; j < m; j++)
        for (Py_ssize_t k = 0; k < m; k++)
            Clu[j * m + k] = AT2(cl, slot[j], slot[k]);
    buf_release(&cl);
    return 1;
}

/* rows given as a model spec (fix._Model.spec: parts, Point, grid, geodesic, eye): what
 * _Model.rows(x) does, without its frame: A = [0.0] * 2n, b = [0.0] * n, Cl = eye.copy(),
 * p = Point(grid, geodesic, x0, y0), obs.linearise(p, slot0, A, b, Cl) for each (slot0, obs) of
 * parts, in order. The (A, b, Cl) tuple as a new reference, or NULL with the exception raised
 * (by Point or a linearise, as rows() would raise it). */
static PyObject *zero_float = NULL;
static PyObject *linearise_name = NULL;

static int spec_ok(PyObject *spec, Py_ssize_t n)
{
    if (!PyTuple_CheckExact(spec) || PyTuple_GET_SIZE(spec) != 5)
        return 0;
    PyObject *parts = PyTuple_GET_ITEM(spec, 0);
    if (!PyTuple_CheckExact(parts))
        return 0;
    for (Py_ssize_t i = 0; i < PyTuple_GET_SIZE(parts); i++) {
        PyObject *t = PyTuple_GET_ITEM(parts, i);
        if (!PyTuple_CheckExact(t) || PyTuple_GET_SIZE(t) != 2 ||
            !PyLong_CheckExact(PyTuple_GET_ITEM(t, 0)))
            return 0;
    }
    np_fields_t *e = np_direct(PyTuple_GET_ITEM(spec, 4), 2);
    if (e == NULL || PyArray_DIMS(e)[0] != n || PyArray_DIMS(e)[1] != n ||
        PyArray_STRIDES(e)[1] != 8 || PyArray_STRIDES(e)[0] != 8 * n)
        return 0;
    if (zero_float == NULL && (zero_float = PyFloat_FromDouble(0.0)) == NULL)
        return -1;
    if (linearise_name == NULL &&
        (linearise_name = PyUnicode_InternFromString("linearise")) == NULL)
        return -1;
    return 1;
}

static PyObject *spec_rows(PyObject *spec, double x0, double y0, Py_ssize_t n)
{
    PyObject *A = PyList_New(2 * n), *b = PyList_New(n), *cl = NULL, *p = NULL, *res = NULL;
    if (A == NULL || b == NULL)
        goto done;
    for (Py_ssize_t i = 0; i < 2 * n; i++)
        PyList_SET_ITEM(A, i, Py_NewRef(zero_float));
    for (Py_ssize_t i = 0; i < n; i++)
        PyList_SET_ITEM(b, i, Py_NewRef(zero_float));
    double *cd;
    if ((cl = lsq_new(n, n, &cd)) == NULL)
        goto done;
    memcpy(cd, PyArray_BYTES((PyArrayObject *)PyTuple_GET_ITEM(spec, 4)), sizeof(double) * n * n);
    {
        PyObject *xo = PyFloat_FromDouble(x0), *yo = PyFloat_FromDouble(y0);
        if (xo != NULL && yo != NULL) {
            PyObject *pa[4] = {PyTuple_GET_ITEM(spec, 2), PyTuple_GET_ITEM(spec, 3), xo, yo};
            p = PyObject_Vectorcall(PyTuple_GET_ITEM(spec, 1), pa, 4, NULL);
        }
        Py_XDECREF(xo);
        Py_XDECREF(yo);
        if (p == NULL)
            goto done;
    }
    PyObject *parts = PyTuple_GET_ITEM(spec, 0);
    for (Py_ssize_t i = 0; i < PyTuple_GET_SIZE(parts); i++) {
        PyObject *t = PyTuple_GET_ITEM(parts, i);
        PyObject *ca[6] = {PyTuple_GET_ITEM(t, 1), p, PyTuple_GET_ITEM(t, 0), A, b, cl};
        PyObject *r = PyObject_VectorcallMethod(linearise_name, ca,
                                                6 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        if (r == NULL)
            goto done;
        Py_DECREF(r);
    }
    res = PyTuple_Pack(3, A, b, cl);
done:
    Py_XDECREF(A);
    Py_XDECREF(b);
    Py_XDECREF(cl);
    Py_XDECREF(p);
    return res;
}

static PyObject *lsq_adjust(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 9) {
        PyErr_SetString(PyExc_TypeError,
                        "adjust(rows, x, used, eps, max_iter, cond_max, max_axis_ratio, "
                        "scale_vcv, d0)");
        return NULL;
    }
    if (need_bound() < 0 || adjust_ready() < 0)
        return NULL;
    PyObject *rows = args[0], *x0o = args[1], *usedo = args[2];
    double eps = PyFloat_AsDouble(args[3]);
    if (eps == -1.0 && PyErr_Occurred())
        return NULL;
    long max_iter = PyLong_AsLong(args[4]);
    if (max_iter == -1 && PyErr_Occurred())
        return NULL;
    double cond_max = PyFloat_AsDouble(args[5]);
    if (cond_max == -1.0 && PyErr_Occurred())
        return NULL;
    double max_ratio = PyFloat_AsDouble(args[6]);
    if (max_ratio == -1.0 && PyErr_Occurred())
        return NULL;
    int scale_vcv = PyObject_IsTrue(args[7]);
    if (scale_vcv < 0)
        return NULL;
    double d0 = PyFloat_AsDouble(args[8]);
    if (d0 == -1.0 && PyErr_Occurred())
        return NULL;

    /* the start: x (2,) finite, the used slots */
    buf_t xb = {0};
    if (buf_get(x0o, &xb, 1) < 0)
        return Py_NewRef(Py_None);
    int xok = xb.view.shape[0] == 2 && isfinite(AT1(xb, 0)) && isfinite(AT1(xb, 1));
    buf_release(&xb);
    if (!xok)
        return Py_NewRef(Py_None);
    Py_buffer ub;
    if (PyObject_GetBuffer(usedo, &ub, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        PyErr_Clear();
        return Py_NewRef(Py_None);
    }
    Py_ssize_t n = ub.len, m = 0;
    Py_ssize_t slot[MAXM];
    int uok = ub.ndim == 1 && ub.itemsize == 1 && ub.format != NULL &&
              strcmp(ub.format, "?") == 0;
    if (uok) {
        const unsigned char *u8 = (const unsigned char *)ub.buf;
        for (Py_ssize_t i = 0; i < n && uok; i++)
            if (u8[i]) {
                if (m == MAXM)
                    uok = 0;
                else
                    slot[m++] = i;
            }
    }
    PyBuffer_Release(&ub);
    if (!uok || m < 2)
        return Py_NewRef(Py_None);
    int spec = PyCallable_Check(rows) ? 0 : spec_ok(rows, n);
    if (spec < 0)
        return NULL;
    if (!spec && !PyCallable_Check(rows))
        return Py_NewRef(Py_None);

    /* the loop of _iterate: each iteration's numbers in C, x as a new array per step */
    _Alignas(64) double Au[2 * MAXM];
    _Alignas(64) double bu[MAXM];
    _Alignas(64) double Clu[MAXM * MAXM];
    step_t sc;
    PyObject *steps = PyList_New(0);
    if (steps == NULL)
        return NULL;
    PyObject *x = Py_NewRef(x0o), *xprev = NULL;
    long it = 0;
    int converged = 0;
    PyObject *res = NULL;
    for (;;) {
        it++;
        PyObject *got;
        if (spec) {
            buf_get(x, &xb, 1); /* x is a (2,) float64 array: the start (checked) or ours */
            double s0 = AT1(xb, 0), s1 = AT1(xb, 1);
            buf_release(&xb);
            got = spec_rows(rows, s0, s1, n);
        }
        else
            got = PyObject_CallOneArg(rows, x);
        if (got == NULL) {
            if (!PyErr_ExceptionMatches(PyExc_Exception))
                goto error;
            PyErr_Clear(); /* the Python calls it again and says why */
            goto back;
        }
        double xc[2];
        buf_get(x, &xb, 1); /* x is a (2,) float64 array: the start (checked) or ours */
        xc[0] = AT1(xb, 0);
        xc[1] = AT1(xb, 1);
        buf_release(&xb);
        int ok = gather(got, n, slot, m, Au, bu, Clu);
        Py_DECREF(got);
        if (!ok || !step_calc(&sc, Au, bu, Clu, m, 1, m, cond_max, xc[0], xc[1]))
            goto back;
        PyObject *len = call_py_hypot(sc.dx[0], sc.dx[1]);
        if (len == NULL)
            goto error;
        int e = PyList_Append(steps, len);
        Py_DECREF(len);
        if (e < 0)
            goto error;
        PyObject *xn = array_of(2, -1, sc.xn);
        if (xn == NULL)
            goto error;
        Py_XSETREF(xprev, x);
        x = xn;
        if (sc.big < eps) {
            converged = 1;
            break;
        }
        if (it >= max_iter)
            break;
    }
    /* the last iteration stands: _check_axis_ratio (_axis_ratio2), then finish; a decline
     * from here on goes back to before the last iteration */
    {
        double a = sc.i00, c = sc.i01, d = sc.i11;
        PyObject *ho = call_py_hypot(0.5 * (a - d), c);
        if (ho == NULL)
            goto error;
        double lmax = 0.5 * (a + d) + PyFloat_AS_DOUBLE(ho);
        Py_DECREF(ho);
        double det = a * d - c * c;
        if (!(lmax > 0.0 && det > 0.0))
            goto back_last;
        double ratio = lmax / sqrt(det);
        if (!(ratio <= max_ratio))
            goto back_last;
    }
    PyObject *ao = NULL, *bo = NULL, *clo = NULL, *wo = NULL, *cxo = NULL, *dxo = NULL;
    PyObject *stepst = NULL, *d = NULL;
    fin_t f = {0};
    int fin = 0;
    if ((cxo = array_of(2, 2, sc.cx)) == NULL)
        goto fail;
    fin = finish_calc(&f, Au, bu, Clu, m, 1, sc.W, sc.atw, sc.cx, cxo, sc.gain, sc.dx, slot, m,
                      n, scale_vcv, d0);
    if (fin < 0)
        goto fail;
    if (fin == 0) {
        Py_DECREF(cxo);
        goto back_last;
    }
    if ((ao = array_of(m, 2, Au)) == NULL || (bo = array_of(m, -1, bu)) == NULL ||
        (clo = array_of(m, m, Clu)) == NULL || (wo = array_of(m, m, sc.W)) == NULL ||
        (dxo = array_of(2, -1, sc.dx)) == NULL || (stepst = PyList_AsTuple(steps)) == NULL)
        goto fail;
    Py_ssize_t r = m - 2;
    PyObject *vals[N_ADJ_KEYS] = {
        converged ? Py_True : Py_False, converged ? Py_None : no_convergence, x, f.covo, cxo,
        usedo, NULL, NULL, NULL, cat_names[r == 0 ? 1 : (r == 1 ? 2 : 3)], NULL,
        converged ? Py_True : Py_False, stepst, dxo, f.vo, f.s2o, NULL, NULL, f.stato, ao, bo,
        clo, wo, Py_None, f.scaled ? Py_True : Py_False, Py_None};
    PyObject *made[5] = {PyLong_FromSsize_t(m), PyLong_FromLong(2), PyLong_FromSsize_t(r),
                         PyLong_FromLong(it), NULL};
    PyObject *fl[2] = {PyFloat_FromDouble(f.rms), PyFloat_FromDouble(f.drms)};
    vals[6] = made[0];
    vals[7] = made[1];
    vals[8] = made[2];
    vals[10] = made[3];
    vals[16] = fl[0];
    vals[17] = fl[1];
    int bad = 0;
    for (int i = 0; i < N_ADJ_KEYS; i++)
        if (vals[i] == NULL)
            bad = 1;
    if (!bad && (d = PyDict_New()) != NULL) {
        for (int i = 0; i < N_ADJ_KEYS && d != NULL; i++)
            if (PyDict_SetItem(d, adj_keys[i], vals[i]) < 0)
                Py_CLEAR(d);
    }
    for (int i = 0; i < 4; i++)
        Py_XDECREF(made[i]);
    Py_XDECREF(fl[0]);
    Py_XDECREF(fl[1]);
    res = d;
fail:
    Py_XDECREF(ao);
    Py_XDECREF(bo);
    Py_XDECREF(clo);
    Py_XDECREF(wo);
    Py_XDECREF(cxo);
    Py_XDECREF(dxo);
    Py_XDECREF(stepst);
    if (fin == 1) {
        Py_XDECREF(f.vo);
        Py_XDECREF(f.covo);
        Py_XDECREF(f.stato);
        Py_XDECREF(f.s2o);
    }
    goto done;
back_last: /* the Python runs the last iteration again (its failure or its rare branch) */
    if (PyList_SetSlice(steps, PyList_GET_SIZE(steps) - 1, PyList_GET_SIZE(steps), NULL) < 0)
        goto error;
    Py_SETREF(x, xprev);
    xprev = NULL;
back: /* iterations 1 .. it - 1 done: the Python goes on from there */
    if (it <= 1)
        res = Py_NewRef(Py_None);
    else
        res = Py_BuildValue("(lOO)", it - 1, x, steps);
    goto done;
error:
    res = NULL;
done:
    Py_XDECREF(x);
    Py_XDECREF(xprev);
    Py_DECREF(steps);
    return res;
}

/* ---------------------------------------------------------------------------------------- */
/* ellipse */

static const double RAD_TO_DEG = 180.0 / 3.14159265358979323846; /* CPython's radToDeg */

/* Python's float % for a positive divisor (float_rem) */
static double py_mod(double vx, double wx)
{
    double mod = vfmod(vx, wx);
    if (mod) {
        if ((wx < 0) != (mod < 0))
            mod += wx;
    }
    else
        mod = copysign(0.0, wx);
    return mod;
}

PyDoc_STRVAR(ellipse_doc,
"ellipse(C2) -> Ellipse or None\n"
"\n"
"engine.lsq.confidence.error_ellipse of a float64 (2, 2) VCV [m^2] (closed form, 5.22-5.23);\n"
"None where the Python must run (another type or shape, non-finite values, a zero norm).");

static PyObject *lsq_ellipse(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 1) {
        PyErr_SetString(PyExc_TypeError, "ellipse(C2)");
        return NULL;
    }
    if (need_bound() < 0)
        return NULL;
    buf_t c = {0};
    if (buf_get(args[0], &c, 2) < 0)
        return Py_NewRef(Py_None);
    if (c.view.shape[0] != 2 || c.view.shape[1] != 2) {
        buf_release(&c);
        return Py_NewRef(Py_None);
    }
    double sxx = AT2(c, 0, 0), sxy = AT2(c, 0, 1), syy = AT2(c, 1, 1);
    buf_release(&c);
    if (!(isfinite(sxx) && isfinite(sxy) && isfinite(syy)))
        return Py_NewRef(Py_None);
    double half = 0.5 * (sxx + syy);
    double hd = 0.5 * (sxx - syy);
    PyObject *ro = call_py_hypot(hd, sxy);
    if (ro == NULL)
        return NULL;
    double root = PyFloat_AS_DOUBLE(ro);
    Py_DECREF(ro);
    double l1 = half + root, l2 = half - root;
    double ee, en;
    if (sxy == 0.0 && hd == 0.0) {
        ee = 1.0;
        en = 0.0;
    }
    else if (sxx >= syy) {
        ee = l1 - syy;
        en = sxy;
    }
    else {
        ee = sxy;
        en = l1 - sxx;
    }
    PyObject *no = call_py_hypot(ee, en);
    if (no == NULL)
        return NULL;
    double norm = PyFloat_AS_DOUBLE(no);
    Py_DECREF(no);
    if (norm == 0.0)
        return Py_NewRef(Py_None); /* the Python raises ZeroDivisionError */
    ee = ee / norm;
    en = en / norm;
    if (ee < 0.0 || (ee == 0.0 && en < 0.0)) {
        ee = -ee;
        en = -en;
    }
    double az = py_mod(vatan2(ee, en) * RAD_TO_DEG, 180.0);
    double phi = vatan2(en, ee) * RAD_TO_DEG;
    double *vec;
    PyObject *veco = lsq_new(2, 2, &vec);
    if (veco == NULL)
        return NULL;
    vec[0] = ee;
    vec[1] = -en;
    vec[2] = en;
    vec[3] = ee;
    double ma = (0.0 > l1) ? 0.0 : l1, mb = (0.0 > l2) ? 0.0 : l2; /* Python's max(l, 0.0) */
    PyObject *vals[6] = {PyFloat_FromDouble(sqrt(ma)), PyFloat_FromDouble(sqrt(mb)),
                         PyFloat_FromDouble(az), Py_BuildValue("(dd)", l1, l2), veco,
                         PyFloat_FromDouble(phi)};
    PyObject *obj = NULL, *dict = NULL, *empty = NULL;
    for (int i = 0; i < 6; i++)
        if (vals[i] == NULL)
            goto fail;
    empty = PyTuple_New(0);
    if (empty == NULL)
        goto fail;
    obj = PyBaseObject_Type.tp_new((PyTypeObject *)ellipse_type, empty, NULL);
    if (obj == NULL)
        goto fail;
    dict = PyObject_GenericGetDict(obj, NULL);
    if (dict == NULL)
        goto fail;
    for (int i = 0; i < 6; i++)
        if (PyDict_SetItem(dict, ellipse_keys[i], vals[i]) < 0)
            goto fail;
    Py_DECREF(dict);
    Py_DECREF(empty);
    for (int i = 0; i < 6; i++)
        Py_DECREF(vals[i]);
    return obj;
fail:
    Py_XDECREF(dict);
    Py_XDECREF(obj);
    Py_XDECREF(empty);
    for (int i = 0; i < 6; i++)
        Py_XDECREF(vals[i]);
    return NULL;
}

/* ---------------------------------------------------------------------------------------- */
/* data snooping: the worst w and the monitor band */

/* The slots i < n with k < |x_i| <= bound (x_i at p + i * stride, bytes), in hit; their
 * count, or -1 for more than MAXM (the caller leaves it to the Python). */
static Py_ssize_t band_slots(const char *p, Py_ssize_t stride, Py_ssize_t n, double k,
                             double bound, Py_ssize_t *hit)
{
    Py_ssize_t cnt = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        double a = fabs(*(const double *)(p + i * stride));
        if (k < a && a <= bound) {
            if (cnt == MAXM)
                return -1;
            hit[cnt++] = i;
        }
    }
    return cnt;
}

/* The tuple of the cnt slots in hit, as Python ints (monitor's and quiet's result). */
static PyObject *slot_tuple(const Py_ssize_t *hit, Py_ssize_t cnt)
{
    PyObject *t = PyTuple_New(cnt);
    if (t == NULL)
        return NULL;
    for (Py_ssize_t j = 0; j < cnt; j++) {
        PyObject *v = PyLong_FromSsize_t(hit[j]);
        if (v == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, j, v);
    }
    return t;
}

PyDoc_STRVAR(quiet_doc,
"quiet(stats, k, bound) -> tuple of the monitor band's slots, or None\n"
"\n"
"snooping's test of a final adjustment when nothing is to be rejected: the largest |w| of\n"
"row 1 of the statistics block (snooping._worst) is within bound; then the slots with\n"
"k < |w| <= bound (as monitor()). None when the snooping loop has something to do (or all\n"
"w are NaN, or another array): the Python runs.");

static PyObject *lsq_quiet(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "quiet(stats, k, bound)");
        return NULL;
    }
    double kc = PyFloat_AsDouble(args[1]);
    if (kc == -1.0 && PyErr_Occurred())
        return NULL;
    double bound_w = PyFloat_AsDouble(args[2]);
    if (bound_w == -1.0 && PyErr_Occurred())
        return NULL;
    buf_t st = {0};
    if (buf_get(args[0], &st, 2) < 0)
        return Py_NewRef(Py_None);
    Py_ssize_t n = st.view.shape[1], k = 0, cnt = 0;
    Py_ssize_t hit[MAXM];
    double best = -1.0;
    int ok = st.view.shape[0] >= 2 && n >= 1;
    for (Py_ssize_t i = 0; ok && i < n; i++) { /* snooping._worst */
        double a = fabs(AT2(st, 1, i));
        if (a > best) {
            k = i;
            best = a;
        }
    }
    if (ok && !(fabs(AT2(st, 1, k)) <= bound_w))
        ok = 0; /* _snoop's loop goes on: the Python */
    if (ok) { /* monitor() */
        cnt = band_slots((const char *)st.view.buf + st.view.strides[0], st.view.strides[1], n,
                         kc, bound_w, hit);
        ok = cnt >= 0;
    }
    buf_release(&st);
    if (!ok)
        return Py_NewRef(Py_None);
    return slot_tuple(hit, cnt);
}

/* ---------------------------------------------------------------------------------------- */

PyDoc_STRVAR(bind_doc,
"_bind(addresses, math_hypot, solution_type, ellipse_type, np_power, np_hypot)\n"
"\n"
"Bind (the first argument is ignored: the kernel's small-matrix code is its own) math.hypot, adjustment._Solution, confidence.Ellipse and\n"
"the ufuncs numpy.power and numpy.hypot; called once, on first use.");

static PyObject *lsq_bind(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "_bind needs 6 arguments");
        return NULL;
    }
    /* args[0] (routine addresses once) is ignored: the small-matrix code is uvn_linalg.h */
    if (!PyType_Check(args[2]) || !PyType_IsSubtype((PyTypeObject *)args[2], &PyTuple_Type) ||
        !PyType_Check(args[3])) {
        PyErr_SetString(PyExc_TypeError, "_bind: a tuple type and a class expected");
        return NULL;
    }
    static const char *names[6] = {"a_m", "b_m", "az_deg", "eigenvalues", "eigenvectors",
                                   "phi_deg"};
    for (int i = 0; i < 6; i++)
        if (ellipse_keys[i] == NULL) {
            ellipse_keys[i] = PyUnicode_InternFromString(names[i]);
            if (ellipse_keys[i] == NULL)
                return NULL;
        }
    if (np_ready() < 0) /* uvn_numpy.h looks numpy.empty up itself */
        return NULL;
    if (minus_half == NULL && (minus_half = PyFloat_FromDouble(-0.5)) == NULL)
        return NULL;
    Py_XSETREF(py_hypot, Py_NewRef(args[1]));
    Py_XSETREF(np_power, Py_NewRef(args[4]));
    Py_XSETREF(np_hypot, Py_NewRef(args[5]));
    Py_XSETREF(sol_type, (PyTypeObject *)Py_NewRef(args[2]));
    Py_XSETREF(ellipse_type, Py_NewRef(args[3]));
    bound = 1;
    Py_RETURN_NONE;
}

/* ---------------------------------------------------------------------------------------- */
/* row: a frozen slotted dataclass instance (fix.LopRow) without its generated __init__ */

#define MAXROW 32
static PyTypeObject *row_type = NULL;
static PyObject *row_names = NULL; /* the fields' names (a tuple of str), field order */
static Py_ssize_t row_n = 0;

/* object.__new__(row_type) with each field set as object.__setattr__ sets it (the frozen
 * dataclass's own __setattr__ refuses): a new reference, or NULL (exception set). */
static PyObject *row_new(PyObject *const *vals)
{
    PyObject *obj = row_type->tp_alloc(row_type, 0);
    for (Py_ssize_t i = 0; i < row_n && obj != NULL; i++)
        if (PyObject_GenericSetAttr(obj, PyTuple_GET_ITEM(row_names, i), vals[i]) < 0)
            Py_CLEAR(obj);
    return obj;
}

PyDoc_STRVAR(bind_row_doc,
"_bind_row(cls, names)\n"
"\n"
"Bind the class row() builds: a frozen dataclass with __slots__ = names (its fields, in\n"
"order), no __dict__, no weakref slot and nothing done by __init__ but setting the fields.");

static PyObject *lsq_bind_row(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2 || !PyType_Check(args[0]) || !PyTuple_Check(args[1])) {
        PyErr_SetString(PyExc_TypeError, "_bind_row(cls, names)");
        return NULL;
    }
    PyTypeObject *tp = (PyTypeObject *)args[0];
    Py_ssize_t n = PyTuple_GET_SIZE(args[1]);
    if (n < 1 || n > MAXROW || tp->tp_itemsize != 0 || tp->tp_dictoffset != 0 ||
        tp->tp_weaklistoffset != 0 || tp->tp_base != &PyBaseObject_Type ||
        tp->tp_basicsize != (Py_ssize_t)(sizeof(PyObject) + n * sizeof(PyObject *))) {
        PyErr_SetString(PyExc_TypeError, "_bind_row: a plain slotted class with these fields");
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *name = PyTuple_GET_ITEM(args[1], i);
        PyObject *d = PyObject_GetAttr(args[0], name);
        if (d == NULL)
            return NULL;
        int ok = Py_IS_TYPE(d, &PyMemberDescr_Type); /* a __slots__ member (data descriptor) */
        Py_DECREF(d);
        if (!ok) {
            PyErr_SetString(PyExc_TypeError, "_bind_row: a field is not an object slot");
            return NULL;
        }
    }
    Py_XSETREF(row_names, Py_NewRef(args[1]));
    row_n = n;
    Py_XSETREF(row_type, (PyTypeObject *)Py_NewRef(args[0]));
    Py_RETURN_NONE;
}

PyDoc_STRVAR(row_doc,
"row(*values) -> an instance of the class bound by _bind_row, fields = values (all given)");

static PyObject *lsq_row(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (row_type == NULL || nargs != row_n) {
        PyErr_SetString(PyExc_TypeError, "row: not bound, or not one value per field");
        return NULL;
    }
    return row_new(args);
}

/* ---------------------------------------------------------------------------------------- */
/* lop_rows: the LOP table of fix._lop_rows in one call */

PyDoc_STRVAR(lop_rows_doc,
"lop_rows(groups, stats, v, used, k, bound) -> list of rows or None\n"
"\n"
"engine.lsq.fix._lop_rows_py: groups a list of (first slot, the system's LopReadings), stats\n"
"the (>= 4, n) statistics block, v (n,) float64, used (n,) bool; one row() per reading with\n"
"its tests and verdict (k < |w| <= bound: monitor). None where the Python must run (row()\n"
"not bound, other types, a slot outside 0..n-1).");

#define N_READING 7
static PyObject *reading_names[N_READING]; /* index, system, pattern, read, correction, ... */
static PyObject *verdicts[4];              /* "", "reject", "monitor", "accept" */

static int lop_rows_ready(void)
{
    static const char *names[N_READING] = {"index", "system", "pattern", "read", "correction",
                                           "calc", "az_deg"};
    static const char *words[4] = {"", "reject", "monitor", "accept"};
    if (verdicts[3] != NULL)
        return 0;
    for (int i = 0; i < N_READING; i++)
        if ((reading_names[i] = PyUnicode_InternFromString(names[i])) == NULL)
            return -1;
    for (int i = 0; i < 4; i++)
        if ((verdicts[i] = PyUnicode_InternFromString(words[i])) == NULL)
            return -1;
    return 0;
}

static PyObject *lsq_lop_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "lop_rows(groups, stats, v, used, k, bound)");
        return NULL;
    }
    if (lop_rows_ready() < 0)
        return NULL;
    double kc = PyFloat_AsDouble(args[4]);
    if (kc == -1.0 && PyErr_Occurred())
        return NULL;
    double bound_w = PyFloat_AsDouble(args[5]);
    if (bound_w == -1.0 && PyErr_Occurred())
        return NULL;
    PyObject *groups = args[0];
    if (row_type == NULL || row_n != 14 || !PyList_CheckExact(groups))
        return Py_NewRef(Py_None);
    buf_t st = {0}, vb = {0};
    Py_buffer ub;
    int ub_held = 0;
    PyObject *res = NULL, *out = NULL;
    if (buf_get(args[1], &st, 2) < 0 || buf_get(args[2], &vb, 1) < 0)
        goto none;
    if (PyObject_GetBuffer(args[3], &ub, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0) {
        PyErr_Clear();
        goto none;
    }
    ub_held = 1;
    Py_ssize_t n = ub.len;
    if (ub.ndim != 1 || ub.itemsize != 1 || ub.format == NULL || strcmp(ub.format, "?") != 0 ||
        st.view.shape[0] < 4 || st.view.shape[1] != n || vb.view.shape[0] != n)
        goto none;
    const unsigned char *used = (const unsigned char *)ub.buf;
    Py_ssize_t ng = PyList_GET_SIZE(groups);
    for (Py_ssize_t g = 0; g < ng; g++) { /* the types first: nothing made for a decline */
        PyObject *gr = PyList_GET_ITEM(groups, g);
        if (!PyTuple_CheckExact(gr) || PyTuple_GET_SIZE(gr) != 2 ||
            !PyLong_CheckExact(PyTuple_GET_ITEM(gr, 0)) ||
            !PyList_CheckExact(PyTuple_GET_ITEM(gr, 1)))
            goto none;
    }
    if ((out = PyList_New(0)) == NULL)
        goto error;
    for (Py_ssize_t g = 0; g < ng; g++) {
        PyObject *gr = PyList_GET_ITEM(groups, g), *rl = PyTuple_GET_ITEM(gr, 1);
        Py_ssize_t first = PyLong_AsSsize_t(PyTuple_GET_ITEM(gr, 0));
        if (first == -1 && PyErr_Occurred()) {
            PyErr_Clear();
            goto none;
        }
        for (Py_ssize_t i = 0; i < PyList_GET_SIZE(rl); i++) {
            PyObject *rd = PyList_GET_ITEM(rl, i);
            PyObject *f[N_READING] = {NULL};
            int ok = 1;
            for (int j = 0; j < N_READING && ok; j++)
                if ((f[j] = PyObject_GetAttr(rd, reading_names[j])) == NULL)
                    ok = 0;
            Py_ssize_t slot = -1;
            if (ok && PyLong_CheckExact(f[0])) {
                Py_ssize_t idx = PyLong_AsSsize_t(f[0]);
                if (!(idx == -1 && PyErr_Occurred()) && idx >= 0 && idx < n - first)
                    slot = first + idx;
            }
            PyErr_Clear();
            PyObject *row = NULL;
            if (ok && slot >= 0) {
                double w = AT2(st, 1, slot), aw = fabs(w);
                PyObject *verdict = w != w ? verdicts[0]
                                    : (aw > bound_w ? verdicts[1]
                                                    : (aw > kc ? verdicts[2] : verdicts[3]));
                PyObject *vals[14] = {PyLong_FromSsize_t(slot), f[1], f[2], f[3], f[4], f[5],
                                      PyFloat_FromDouble(AT1(vb, slot)), f[6],
                                      used[slot] ? Py_True : Py_False,
                                      PyFloat_FromDouble(AT2(st, 0, slot)),
                                      PyFloat_FromDouble(w), PyFloat_FromDouble(AT2(st, 2, slot)),
                                      PyFloat_FromDouble(AT2(st, 3, slot)), verdict};
                static const int made[6] = {0, 6, 9, 10, 11, 12};
                int good = 1;
                for (int j = 0; j < 6; j++)
                    if (vals[made[j]] == NULL)
                        good = 0;
                if (good)
                    row = row_new(vals);
                for (int j = 0; j < 6; j++)
                    Py_XDECREF(vals[made[j]]);
                if (row == NULL && !PyErr_Occurred())
                    PyErr_NoMemory();
            }
            for (int j = 0; j < N_READING; j++)
                Py_XDECREF(f[j]);
            if (!ok || slot < 0) {
                PyErr_Clear();
                goto none; /* the Python raises or indexes as it does */
            }
            if (row == NULL)
                goto error;
            int e = PyList_Append(out, row);
            Py_DECREF(row);
            if (e < 0)
                goto error;
        }
    }
    res = out;
    out = NULL;
    goto done;
none:
    res = Py_NewRef(Py_None);
    goto done;
error:
    res = NULL;
done:
    Py_XDECREF(out);
    if (ub_held)
        PyBuffer_Release(&ub);
    buf_release(&st);
    buf_release(&vb);
    return res;
}

/* ---------------------------------------------------------------------------------------- */
/* adjust_tested: adjust() and compute_fix's tests of a quiet fix, the results built here */

PyDoc_STRVAR(bind_fix_doc,
"_bind_fix(adjustment_cls, tested_cls, variance_test_cls, variance_bounds, point_cls,\n"
"          decca_cls, fix_cls, decca_name, bool_dtype)\n"
"\n"
"Bind what adjust_tested() and estimate() build and call: adjustment.Adjustment,\n"
"snooping.TestedAdjustment, statistics.UnitVarianceTest, fix.FixResult (frozen dataclasses\n"
"with an instance dict, nothing done by __init__ but setting the fields),\n"
"statistics._variance_bounds, systems.base.Point, decca.DeccaObservations and the Decca\n"
"system's name (its key in a fix's observation sets); bool_dtype numpy.dtype(bool).");

static PyObject *fix_cls[3] = {NULL, NULL, NULL}; /* Adjustment, TestedAdjustment, UVT */
static PyObject *variance_bounds = NULL;
static PyObject *est_cls[3] = {NULL, NULL, NULL}; /* Point, DeccaObservations, FixResult */
static PyObject *decca_key = NULL;                /* the Decca system's name */
static PyObject *bool_descr = NULL;               /* numpy.dtype(bool) */
static PyObject *dict_name = NULL, *empty_args = NULL;
#define N_VT_KEYS 5
#define N_TA_KEYS 12
static PyObject *vt_keys[N_VT_KEYS], *ta_keys[N_TA_KEYS];

static PyObject *lsq_bind_fix(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 9 || !PyType_Check(args[0]) || !PyType_Check(args[1]) ||
        !PyType_Check(args[2]) || !PyCallable_Check(args[3]) || !PyType_Check(args[4]) ||
        !PyType_Check(args[5]) || !PyType_Check(args[6]) || !PyUnicode_CheckExact(args[7])) {
        PyErr_SetString(PyExc_TypeError, "_bind_fix(adjustment_cls, tested_cls, "
                                         "variance_test_cls, variance_bounds, point_cls, "
                                         "decca_cls, fix_cls, decca_name, bool_dtype)");
        return NULL;
    }
    static const char *vn[N_VT_KEYS] = {"statistic", "lower", "upper", "accepted", "dof"};
    static const char *tn[N_TA_KEYS] = {
        "adjustment", "rejected", "candidate", "candidate_w", "flagged", "monitor",
        "not_identifiable", "variance_test", "messages", "policy", "estimator", "robust"};
    if (dict_name == NULL) {
        if ((dict_name = PyUnicode_InternFromString("__dict__")) == NULL ||
            (empty_args = PyTuple_New(0)) == NULL)
            return NULL;
        for (int i = 0; i < N_VT_KEYS; i++)
            if ((vt_keys[i] = PyUnicode_InternFromString(vn[i])) == NULL)
                return NULL;
        for (int i = 0; i < N_TA_KEYS; i++)
            if ((ta_keys[i] = PyUnicode_InternFromString(tn[i])) == NULL)
                return NULL;
    }
    for (int i = 0; i < 4; i++) {
        PyTypeObject *tp = (PyTypeObject *)args[i == 3 ? 6 : i];
        if (tp->tp_dictoffset == 0 || tp->tp_new != PyBaseObject_Type.tp_new) {
            PyErr_SetString(PyExc_TypeError, "_bind_fix: classes with an instance dict");
            return NULL;
        }
    }
    for (int i = 0; i < 3; i++)
        Py_XSETREF(fix_cls[i], Py_NewRef(args[i]));
    Py_XSETREF(variance_bounds, Py_NewRef(args[3]));
    for (int i = 0; i < 3; i++)
        Py_XSETREF(est_cls[i], Py_NewRef(args[4 + i]));
    Py_XSETREF(decca_key, Py_NewRef(args[7]));
    Py_XSETREF(bool_descr, Py_NewRef(args[8]));
    Py_RETURN_NONE;
}

/* frozen_instance(cls, d): object.__new__(cls) with d as its instance dict (d's reference
 * taken over, also on failure). New reference or NULL. */
static PyObject *with_dict(PyObject *cls, PyObject *d)
{
    if (d == NULL)
        return NULL;
    PyObject *obj = PyBaseObject_Type.tp_new((PyTypeObject *)cls, empty_args, NULL);
    if (obj != NULL && uvn_set_attrs(obj, d) < 0)
        Py_CLEAR(obj);
    Py_DECREF(d);
    return obj;
}

/* A new dict of n keys and values, or NULL. */
static PyObject *dict_of(int n, PyObject *const *keys, PyObject *const *vals)
{
    PyObject *d = PyDict_New();
    for (int i = 0; i < n && d != NULL; i++)
        if (vals[i] == NULL || PyDict_SetItem(d, keys[i], vals[i]) < 0)
            Py_CLEAR(d);
    return d;
}

/* numpy.array(x0, dtype=float) of a tuple of two floats and numpy.array(used, dtype=bool) of
 * a list of bools, made here (the same arrays: C-ordered, writable, aligned); anything else is
 * passed on as it is (adjust() reads arrays, and declines what it cannot read). New references
 * in *xo, *uo, or -1 (exception set). */
static int start_arrays(PyObject *x, PyObject *used, PyObject **xo, PyObject **uo)
{
    *xo = *uo = NULL;
    if (PyTuple_CheckExact(x) && PyTuple_GET_SIZE(x) == 2 &&
        PyFloat_CheckExact(PyTuple_GET_ITEM(x, 0)) &&
        PyFloat_CheckExact(PyTuple_GET_ITEM(x, 1))) {
        double *d;
        if ((*xo = lsq_new(2, -1, &d)) == NULL)
            return -1;
        d[0] = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(x, 0));
        d[1] = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(x, 1));
    }
    else
        *xo = Py_NewRef(x);
    Py_ssize_t n = PyList_CheckExact(used) ? PyList_GET_SIZE(used) : -1;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *b = PyList_GET_ITEM(used, i);
        if (b != Py_True && b != Py_False)
            n = -1;
    }
    if (n >= 1 && bool_descr != NULL && np_layout == 1) {
        Py_ssize_t dims[1] = {n};
        Py_INCREF(bool_descr); /* stolen */
        *uo = np_new_from_descr((PyTypeObject *)np_ndarray, bool_descr, 1, dims, NULL, NULL, 0,
                                NULL);
        if (*uo == NULL) {
            Py_CLEAR(*xo);
            return -1;
        }
        unsigned char *u8 = (unsigned char *)PyArray_BYTES((PyArrayObject *)*uo);
        for (Py_ssize_t i = 0; i < n; i++)
            u8[i] = PyList_GET_ITEM(used, i) == Py_True;
    }
    else
        *uo = Py_NewRef(used);
    return 0;
}

PyDoc_STRVAR(adjust_tested_doc,
"adjust_tested(spec, x, used, eps, max_iter, cond_max, max_axis_ratio, scale_vcv, d0, alpha,\n"
"              s02, k, bound, policy, estimator)\n"
"-> TestedAdjustment, Adjustment, dict, (iterations, x, steps) or None\n"
"\n"
"adjust() (its first nine arguments), then what fix._first_py and fix._tested_py do with its\n"
"dict: the unit-variance test (statistics.unit_variance_test: _variance_bounds called, the\n"
"UnitVarianceTest built), the Adjustment, and for a fix that is ok with redundancy >= 1,\n"
"nothing beyond bound and its unit variance accepted (or not tested), snooping._quiet's\n"
"TestedAdjustment (monitor: quiet()'s band). Returns the Adjustment when there is more to do\n"
"(fix._tested_py then), the dict when alpha or s02 is not a float (fix._first_py), adjust()'s\n"
"other results as they are. x may be a tuple of two floats and used a list of bools: the\n"
"arrays compute_fix made of them are made here. _bind_fix first.");

static PyObject *lsq_adjust_tested(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 15) {
        PyErr_SetString(PyExc_TypeError,
                        "adjust_tested(spec, x, used, eps, max_iter, cond_max, max_axis_ratio, "
                        "scale_vcv, d0, alpha, s02, k, bound, policy, estimator)");
        return NULL;
    }
    if (variance_bounds == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "engine.native.lsq: _bind_fix() first");
        return NULL;
    }
    double kc = PyFloat_AsDouble(args[11]);
    if (kc == -1.0 && PyErr_Occurred())
        return NULL;
    double bound_w = PyFloat_AsDouble(args[12]);
    if (bound_w == -1.0 && PyErr_Occurred())
        return NULL;
    PyObject *aa[9], *xo, *uo;
    if (start_arrays(args[1], args[2], &xo, &uo) < 0)
        return NULL;
    memcpy(aa, args, sizeof(aa));
    aa[1] = xo;
    aa[2] = uo;
    PyObject *d = lsq_adjust(self, aa, 9);
    Py_DECREF(xo);
    Py_DECREF(uo);
    if (d == NULL || !PyDict_CheckExact(d))
        return d;
    PyObject *alpha = args[9], *s02o = args[10];
    if (!PyFloat_CheckExact(alpha) || !PyFloat_CheckExact(s02o))
        return d;
    /* fix._first_py: the unit-variance test, then frozen_instance(Adjustment, state) */
    PyObject *s2o = PyDict_GetItemWithError(d, adj_keys[15]);   /* s2 */
    PyObject *ro = PyDict_GetItemWithError(d, adj_keys[8]);     /* redundancy */
    PyObject *oko = PyDict_GetItemWithError(d, adj_keys[0]);    /* ok */
    PyObject *stato = PyDict_GetItemWithError(d, adj_keys[18]); /* stats_block */
    if (s2o == NULL || ro == NULL || oko == NULL || stato == NULL || !PyLong_CheckExact(ro) ||
        !(s2o == Py_None || PyFloat_CheckExact(s2o))) {
        if (PyErr_Occurred()) {
            Py_DECREF(d);
            return NULL;
        }
        return d;
    }
    Py_ssize_t r = PyLong_AsSsize_t(ro);
    if (r == -1 && PyErr_Occurred()) {
        Py_DECREF(d);
        return NULL;
    }
    Py_INCREF(ro);
    Py_INCREF(oko);
    Py_INCREF(stato);
    PyObject *vt = Py_NewRef(Py_None), *adj = NULL, *res = NULL;
    int accepted = 1;
    if (s2o != Py_None) {
        double s2 = PyFloat_AS_DOUBLE(s2o);
        if (r >= 1 && isfinite(s2)) { /* unit_variance_test(s2, r, alpha, s02) */
            PyObject *ca[3] = {ro, alpha, s02o};
            PyObject *b = PyObject_Vectorcall(variance_bounds, ca, 3, NULL);
            if (b == NULL)
                goto error;
            if (!PyTuple_CheckExact(b) || PyTuple_GET_SIZE(b) != 2 ||
                !PyFloat_CheckExact(PyTuple_GET_ITEM(b, 0)) ||
                !PyFloat_CheckExact(PyTuple_GET_ITEM(b, 1))) {
                Py_DECREF(b);
                PyErr_SetString(PyExc_TypeError, "_variance_bounds: not two floats");
                goto error;
            }
            double lower = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(b, 0));
            double upper = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(b, 1));
            accepted = lower < s2 && s2 < upper;
            PyObject *st = PyFloat_FromDouble((double)r * s2 / PyFloat_AS_DOUBLE(s02o));
            PyObject *vv[N_VT_KEYS] = {st, PyTuple_GET_ITEM(b, 0), PyTuple_GET_ITEM(b, 1),
                                       accepted ? Py_True : Py_False, ro};
            Py_SETREF(vt, with_dict(fix_cls[2], dict_of(N_VT_KEYS, vt_keys, vv)));
            Py_XDECREF(st);
            Py_DECREF(b);
            if (vt == NULL)
                goto error;
            if (PyDict_SetItem(d, adj_keys[23], vt) < 0) /* variance_test */
                goto error;
        }
    }
    adj = with_dict(fix_cls[0], d);
    d = NULL;
    if (adj == NULL)
        goto error;
    /* fix._tested_py for a quiet fix: snooping._quiet without messages */
    if (oko != Py_True || r < 1 || !accepted)
        goto first;
    PyObject *qa[3] = {stato, args[11], args[12]};
    PyObject *mon = lsq_quiet(self, qa, 3);
    if (mon == NULL)
        goto error;
    if (mon == Py_None) {
        Py_DECREF(mon);
        goto first;
    }
    PyObject *empty = PyTuple_New(0);
    PyObject *tv[N_TA_KEYS] = {adj, empty, Py_None, Py_None, empty, mon, Py_False, vt, empty,
                               args[13], args[14], Py_None};
    res = with_dict(fix_cls[1], dict_of(N_TA_KEYS, ta_keys, tv));
    Py_XDECREF(empty);
    Py_DECREF(mon);
    goto done;
first:
    res = Py_NewRef(adj);
    goto done;
error:
    res = NULL;
done:
    Py_XDECREF(d);
    Py_XDECREF(adj);
    Py_DECREF(vt);
    Py_DECREF(ro);
    Py_DECREF(oko);
    Py_DECREF(stato);
    return res;
}

/* ---------------------------------------------------------------------------------------- */
/* tail: fix._at_estimate's linear-range check and LOP table in one call */

PyDoc_STRVAR(tail_doc,
"tail(sets, spans, p, used, check, l1, stats, v, used_arr, k, bound) -> tuple of rows or None\n"
"\n"
"engine.lsq.fix._tail_py: with check, fix._beyond_linear_range (near = the min over the\n"
"systems, in sets order, of obs.nearest_station_m(p, used[start:stop]); l1 the larger\n"
"eigenvalue); then lop_rows() of (start, obs.readings(p)) for each system of sets, as a\n"
"tuple. sets a dict name -> ObservationSet, spans a dict name -> (start, stop), used the\n"
"final used slots as a list of bools. None where the Python must run: a fix beyond the\n"
"linear range (it says why), check without l1, an exception of a system (the Python calls\n"
"it again and says why), other types, lop_rows() declining.");

static PyObject *nearest_name = NULL, *readings_name = NULL;

static PyObject *lsq_tail(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 11) {
        PyErr_SetString(PyExc_TypeError,
                        "tail(sets, spans, p, used, check, l1, stats, v, used_arr, k, bound)");
        return NULL;
    }
    if (nearest_name == NULL &&
        ((nearest_name = PyUnicode_InternFromString("nearest_station_m")) == NULL ||
         (readings_name = PyUnicode_InternFromString("readings")) == NULL))
        return NULL;
    PyObject *sets = args[0], *spans = args[1], *p = args[2], *used = args[3];
    int check = PyObject_IsTrue(args[4]);
    if (check < 0)
        return NULL;
    if (!PyDict_CheckExact(sets) || !PyDict_CheckExact(spans) || !PyList_CheckExact(used) ||
        (check && !PyFloat_CheckExact(args[5])))
        return Py_NewRef(Py_None);
    Py_ssize_t ns = PyDict_GET_SIZE(sets), pos = 0, i = 0;
    if (ns > 16)
        return Py_NewRef(Py_None);
    Py_ssize_t start[16], stop[16];
    PyObject *name, *obs, *obj[16];
    while (PyDict_Next(sets, &pos, &name, &obs)) { /* the types first: nothing called */
        PyObject *sp = PyDict_GetItemWithError(spans, name);
        if (sp == NULL || !PyTuple_CheckExact(sp) || PyTuple_GET_SIZE(sp) != 2) {
            PyErr_Clear();
            return Py_NewRef(Py_None);
        }
        start[i] = PyLong_AsSsize_t(PyTuple_GET_ITEM(sp, 0));
        stop[i] = PyLong_AsSsize_t(PyTuple_GET_ITEM(sp, 1));
        if (PyErr_Occurred()) {
            PyErr_Clear();
            return Py_NewRef(Py_None);
        }
        obj[i++] = obs;
    }
    if (i != ns)
        return Py_NewRef(Py_None);
    if (check) { /* _beyond_linear_range */
        double near = INFINITY;
        for (i = 0; i < ns; i++) {
            PyObject *sl = PyList_GetSlice(used, start[i], stop[i]);
            if (sl == NULL)
                return NULL;
            PyObject *ca[3] = {obj[i], p, sl};
            PyObject *r = PyObject_VectorcallMethod(nearest_name, ca,
                                                    3 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
            Py_DECREF(sl);
            if (r == NULL) {
                if (!PyErr_ExceptionMatches(PyExc_Exception))
                    return NULL;
                PyErr_Clear(); /* the Python calls it again and says why */
                return Py_NewRef(Py_None);
            }
            int isf = PyFloat_CheckExact(r);
            double d = isf ? PyFloat_AS_DOUBLE(r) : 0.0;
            Py_DECREF(r);
            if (!isf)
                return Py_NewRef(Py_None);
            if (d < near) /* min(near, d) */
                near = d;
        }
        if (near != INFINITY) { /* _linear_range_reason: a = sqrt(max(l1, 0.0)) */
            double l1 = PyFloat_AS_DOUBLE(args[5]);
            double a = sqrt(0.0 > l1 ? 0.0 : l1);
            if (!(a < near))
                return Py_NewRef(Py_None); /* beyond the linear range: the Python says why */
        }
    }
    PyObject *groups = PyList_New(ns);
    if (groups == NULL)
        return NULL;
    for (i = 0; i < ns; i++) {
        PyObject *ca[2] = {obj[i], p};
        PyObject *r = PyObject_VectorcallMethod(readings_name, ca,
                                                2 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        if (r == NULL) {
            Py_DECREF(groups);
            if (!PyErr_ExceptionMatches(PyExc_Exception))
                return NULL;
            PyErr_Clear();
            return Py_NewRef(Py_None);
        }
        PyObject *g = Py_BuildValue("(nN)", start[i], r);
        if (g == NULL) {
            Py_DECREF(groups);
            return NULL;
        }
        PyList_SET_ITEM(groups, i, g);
    }
    PyObject *la[6] = {groups, args[6], args[7], args[8], args[9], args[10]};
    PyObject *rows = lsq_lop_rows(self, la, 6);
    Py_DECREF(groups);
    if (rows == NULL || rows == Py_None)
        return rows;
    PyObject *t = PyList_AsTuple(rows);
    Py_DECREF(rows);
    return t;
}


/* ---------------------------------------------------------------------------------------- */
/* estimate: fix._at_estimate of a quiet fix (no prior, nothing rejected) in one call */

PyDoc_STRVAR(estimate_doc,
"estimate(grid, geodesic, tested, sets, spans, used, messages, k, bound) -> FixResult or None\n"
"\n"
"engine.lsq.fix._at_estimate for a fix of the LOPs alone (not the hybrid fix) with nothing\n"
"rejected: x_m, y_m of the adjustment's x, grid.inverse of them, the Point there (with its\n"
"lat/lon), the Decca set's geometry_at it, ellipse() of cov_x, then tail() with the check\n"
"(l1 from the ellipse when cov_x is cov_x_apriori) and the FixResult built (messages: a tuple\n"
"of the list). used: the final adjustment's used slots as a list. None (the Python runs, and\n"
"says why) where tail() or ellipse() decline, a system or the grid raises, or a type is not\n"
"the usual one. _bind_fix first.");

#define N_FR_KEYS 21
static PyObject *fr_keys[N_FR_KEYS];
static PyObject *inverse_name, *geometry_at_name, *raw_name, *adjustment_name, *rejected_name,
    *candidate_name, *x_name, *cov_x_name, *cov_x_apriori_name, *category_name, *n_used_name,
    *rms_name, *s2_name, *stats_name, *v_name, *used_name;

static int estimate_ready(void)
{
    static const char *fn[N_FR_KEYS] = {
        "ok", "reason", "x_m", "y_m", "lat_deg", "lon_deg", "cov", "ellipse", "category",
        "n_used", "rms_m", "s2", "lops", "tested", "decca_observed", "decca_geometry",
        "rejected_slots", "candidate_slot", "uses_prior", "messages", "raw_lops"};
    if (used_name != NULL)
        return 0;
    for (int i = 0; i < N_FR_KEYS; i++)
        if ((fr_keys[i] = PyUnicode_InternFromString(fn[i])) == NULL)
            return -1;
    PyObject **dst[16] = {&inverse_name, &geometry_at_name, &raw_name, &adjustment_name,
                          &rejected_name, &candidate_name, &x_name, &cov_x_name,
                          &cov_x_apriori_name, &category_name, &n_used_name, &rms_name,
                          &s2_name, &stats_name, &v_name, &used_name};
    static const char *an[16] = {"inverse", "geometry_at", "raw", "adjustment", "rejected",
                                 "candidate", "x", "cov_x", "cov_x_apriori", "category",
                                 "n_used", "rms_m", "s2", "stats_block", "v", "used"};
    for (int i = 0; i < 16; i++)
        if ((*dst[i] = PyUnicode_InternFromString(an[i])) == NULL)
            return -1;
    return 0;
}

static PyObject *lsq_estimate(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 9) {
        PyErr_SetString(PyExc_TypeError, "estimate(grid, geodesic, tested, sets, spans, used, "
                                         "messages, k, bound)");
        return NULL;
    }
    if (est_cls[2] == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "engine.native.lsq: _bind_fix() first");
        return NULL;
    }
    if (estimate_ready() < 0)
        return NULL;
    PyObject *grid = args[0], *geodesic = args[1], *tested = args[2], *sets = args[3];
    PyObject *messages = args[6];
    if (!PyDict_CheckExact(sets) || !PyList_CheckExact(messages))
        return Py_NewRef(Py_None);
    /* every object made or looked up, released at the end */
    enum { ADJ, REJ, CAND, X, COVX, COVA, CAT, NUSED, RMS, S2, STATS, V, USED, XE, YN, LL,
           LLT, P, GEOM, ELL, L1, LOPS, RAW, MSG, NOBJ };
    PyObject *o[NOBJ] = {NULL};
    PyObject *res = NULL, *decca = NULL;
    if ((o[ADJ] = PyObject_GetAttr(tested, adjustment_name)) == NULL ||
        (o[REJ] = PyObject_GetAttr(tested, rejected_name)) == NULL ||
        (o[CAND] = PyObject_GetAttr(tested, candidate_name)) == NULL)
        goto raised;
    if (!PyTuple_CheckExact(o[REJ]) || PyTuple_GET_SIZE(o[REJ]) != 0)
        goto none; /* rejections: the Python's rejected_slots */
    PyObject *an[10] = {x_name, cov_x_name, cov_x_apriori_name, category_name, n_used_name,
                        rms_name, s2_name, stats_name, v_name, used_name};
    for (int i = 0; i < 10; i++)
        if ((o[X + i] = PyObject_GetAttr(o[ADJ], an[i])) == NULL)
            goto raised;
    /* xe, yn = adj.x.tolist() */
    buf_t xb = {0};
    if (buf_get(o[X], &xb, 1) < 0)
        goto none;
    if (xb.view.shape[0] != 2) {
        buf_release(&xb);
        goto none;
    }
    o[XE] = PyFloat_FromDouble(AT1(xb, 0));
    o[YN] = PyFloat_FromDouble(AT1(xb, 1));
    buf_release(&xb);
    if (o[XE] == NULL || o[YN] == NULL)
        goto error;
    { /* lat, lon = grid.inverse(xe, yn) */
        PyObject *ca[3] = {grid, o[XE], o[YN]};
        o[LL] = PyObject_VectorcallMethod(inverse_name, ca, 3 | PY_VECTORCALL_ARGUMENTS_OFFSET,
                                          NULL);
        if (o[LL] == NULL)
            goto raised;
        if (!PyTuple_CheckExact(o[LL]) || PyTuple_GET_SIZE(o[LL]) != 2)
            goto none;
        o[LLT] = PyTuple_Pack(2, PyTuple_GET_ITEM(o[LL], 0), PyTuple_GET_ITEM(o[LL], 1));
        if (o[LLT] == NULL)
            goto error;
    }
    { /* p_hat = Point(grid, geodesic, xe, yn, (lat, lon)) */
        PyObject *ca[5] = {grid, geodesic, o[XE], o[YN], o[LLT]};
        if ((o[P] = PyObject_Vectorcall(est_cls[0], ca, 5, NULL)) == NULL)
            goto raised;
    }
    /* geom = decca.geometry_at(p_hat) if isinstance(decca, DeccaObservations) else None */
    decca = PyDict_GetItemWithError(sets, decca_key); /* borrowed */
    if (decca == NULL && PyErr_Occurred())
        goto error;
    int is_decca = 0;
    if (decca != NULL) {
        is_decca = PyObject_IsInstance(decca, est_cls[1]);
        if (is_decca < 0)
            goto raised;
    }
    if (is_decca) {
        PyObject *ca[2] = {decca, o[P]};
        o[GEOM] = PyObject_VectorcallMethod(geometry_at_name, ca,
                                            2 | PY_VECTORCALL_ARGUMENTS_OFFSET, NULL);
        if (o[GEOM] == NULL)
            goto raised;
        if ((o[RAW] = PyObject_GetAttr(decca, raw_name)) == NULL)
            goto raised;
    }
    else {
        o[GEOM] = Py_NewRef(Py_None);
        o[RAW] = PyTuple_Pack(3, Py_None, Py_None, Py_None);
        if (o[RAW] == NULL)
            goto error;
    }
    /* ellipse = k.ellipse(adj.cov_x) (the Python's error_ellipse where it declines) */
    {
        PyObject *ca[1] = {o[COVX]};
        o[ELL] = lsq_ellipse(self, ca, 1);
        if (o[ELL] == NULL)
            goto error;
        if (o[ELL] == Py_None)
            goto none;
    }
    /* l1 = ellipse.eigenvalues[0] if adj.cov_x is adj.cov_x_apriori else None */
    if (o[COVX] == o[COVA]) {
        PyObject *ev = PyObject_GetAttr(o[ELL], ellipse_keys[3]);
        if (ev == NULL)
            goto raised;
        if (PyTuple_CheckExact(ev) && PyTuple_GET_SIZE(ev) >= 1)
            o[L1] = Py_NewRef(PyTuple_GET_ITEM(ev, 0));
        Py_DECREF(ev);
        if (o[L1] == NULL)
            goto none;
    }
    else
        o[L1] = Py_NewRef(Py_None);
    { /* the check and the table: tail() */
        PyObject *ta[11] = {sets, args[4], o[P], args[5], Py_True, o[L1], o[STATS], o[V],
                            o[USED], args[7], args[8]};
        o[LOPS] = lsq_tail(self, ta, 11);
        if (o[LOPS] == NULL)
            goto error;
        if (o[LOPS] == Py_None)
            goto none;
    }
    if ((o[MSG] = PyList_AsTuple(messages)) == NULL)
        goto error;
    {
        PyObject *empty = PyTuple_New(0);
        PyObject *fv[N_FR_KEYS] = {
            Py_True, Py_None, o[XE], o[YN], PyTuple_GET_ITEM(o[LL], 0),
            PyTuple_GET_ITEM(o[LL], 1), o[COVX], o[ELL], o[CAT], o[NUSED], o[RMS], o[S2],
            o[LOPS], tested, o[RAW], o[GEOM], empty, o[CAND], Py_False, o[MSG], Py_None};
        res = with_dict(est_cls[2], dict_of(N_FR_KEYS, fr_keys, fv));
        Py_XDECREF(empty);
    }
    goto done;
raised: /* an exception of the objects called: the Python calls them again and says why */
    if (!PyErr_ExceptionMatches(PyExc_Exception))
        goto error;
    PyErr_Clear();
none:
    res = Py_NewRef(Py_None);
    goto done;
error:
    res = NULL;
done:
    for (int i = 0; i < NOBJ; i++)
        Py_XDECREF(o[i]);
    return res;
}

static PyMethodDef methods[] = {
    UVN_PROBE_METHOD,
    {"estimate", (PyCFunction)(void (*)(void))lsq_estimate, METH_FASTCALL, estimate_doc},
    {"_bind_fix", (PyCFunction)(void (*)(void))lsq_bind_fix, METH_FASTCALL, bind_fix_doc},
    {"adjust_tested", (PyCFunction)(void (*)(void))lsq_adjust_tested, METH_FASTCALL,
     adjust_tested_doc},
    {"tail", (PyCFunction)(void (*)(void))lsq_tail, METH_FASTCALL, tail_doc},
    {"_bind_row", (PyCFunction)(void (*)(void))lsq_bind_row, METH_FASTCALL, bind_row_doc},
    {"row", (PyCFunction)(void (*)(void))lsq_row, METH_FASTCALL, row_doc},
    {"lop_rows", (PyCFunction)(void (*)(void))lsq_lop_rows, METH_FASTCALL, lop_rows_doc},
    {"_bind", (PyCFunction)(void (*)(void))lsq_bind, METH_FASTCALL, bind_doc},
    {"adjust", (PyCFunction)(void (*)(void))lsq_adjust, METH_FASTCALL, adjust_doc},
    {"ellipse", (PyCFunction)(void (*)(void))lsq_ellipse, METH_FASTCALL, ellipse_doc},
    {"quiet", (PyCFunction)(void (*)(void))lsq_quiet, METH_FASTCALL, quiet_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "engine.native.lsq",
    "Compiled twin of the least-squares fix's numeric core (engine/lsq), bit for bit.", -1,
    methods,
};

PyMODINIT_FUNC PyInit_lsq(void)
{
    PyObject *mod = PyModule_Create(&module);
    if (mod == NULL)
        return NULL;
    if (PyModule_AddStringConstant(mod, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(mod);
        return NULL;
    }
    return mod;
}
