/* The engine's datum shifts, compiled (engine.native.datum): engine.geodesy.ellipsoidal.DatumShift
 * (the reference, pure Python) computed by the same steps (thesis §5.3, A8.4; docs/THEORY.md
 * §2.1-2.2 and D1). The two agree to the engine's tolerance contract (docs/PERFORMANCE.md);
 * engine.fast.geodesy checks that on first use, tests/native/test_datum.py on every datum of
 * data/TO_WGS84.DAT, on a replay's points and over the whole globe:
 *
 *   1. geodetic (φ, λ, h) on the source ellipsoid → geocentric Cartesian (X, Y, Z):
 *        N = a / √(1 − e² sin²φ),  X = (N + h) cos φ cos λ,  Y = (N + h) cos φ sin λ,
 *        Z = (N (1 − e²) + h) sin φ                          (Torge & Müller, Geodesy, 4th ed.,
 *                                                             2012, §4.1.1, eq. 4.20);
 *   2. the source datum's seven-parameter similarity to WGS84, position-vector convention with
 *      the small-angle rotation matrix (IOGP Guidance Note 7-2, EPSG method 9606):
 *        X' = T + (1 + s·10⁻⁶) R X,  R = [[1, −rz, ry], [rz, 1, −rx], [−ry, rx, 1]] (radians);
 *      with zero rotations and scale the 3-parameter shift X' = X + (dX, dY, dZ);
 *   3. the destination datum's similarity reversed: X = Rᵀ (X' − T) / (1 + s·10⁻⁶);
 *   4. Cartesian → geodetic on the destination ellipsoid by Bowring's formula (Bowring 1976,
 *      Survey Review 23(181):323–327) iterated on the parametric latitude β until it moves by
 *      less than 1e-14 rad:
 *        p = √(X² + Y²), tan β = (1 − f) tan φ (first: Z / ((1 − f) p)),
 *        tan φ = (Z + e'² b sin³β) / (p − e² a cos³β),  λ = atan2(Y, X),
 *        h = p cos φ + Z sin φ − a √(1 − e² sin²φ).
 * Degrees in and out, (lat, lon, h) order. Steps whose seven parameters are all zero (WGS84)
 * are left out, as the reference leaves them out.
 *
 * A Shift object is called as DatumShift.transform: (lat, lon, h) -> (lat, lon, h). It computes
 * three floats that are finite, with |lat| <= 90° and |lon| <= 10 rad; anything else (another
 * argument type, a non-finite value or result, a result on the antimeridian, where the sign of
 * ±180° is the rounding's choice, or within 1° of a pole, where the longitude is that of the
 * rounding of X, Y ≈ 0) goes to the fallback it was made with (the reference's transform).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stddef.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

#define DEG_TO_RAD 0.017453292519943295 /* π / 180 */
#define ARCSEC_TO_RAD (DEG_TO_RAD / 3600.0)

typedef struct {
    double a, b, e2, ep2; /* semi-axes (m), first and second eccentricity squared */
} ell_t;

typedef struct {
    int present;
    double t[3];    /* translation (m) */
    double scale;   /* 1 + s·10⁻⁶ */
    double R[3][3]; /* position-vector small-angle rotation */
} helmert_t;

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *fallback; /* DatumShift.transform: the reference */
    ell_t src, dst;
    helmert_t hsrc, hdst;
} ShiftObject;

/* An ellipsoid (a m, 1/f > 1) or a sphere (rf == 0): 0, or -1 (refused). */
static int ell_init(ell_t *e, double a, double rf)
{
    if (!(a > 0.0) || !isfinite(a) || !(rf == 0.0 || (rf > 1.0 && isfinite(rf))))
        return -1;
    double f = rf == 0.0 ? 0.0 : 1.0 / rf;
    e->a = a;
    e->b = a * (1.0 - f);
    e->e2 = f * (2.0 - f);
    e->ep2 = e->e2 / (1.0 - e->e2);
    return 0;
}

/* (x, y, z m; rx, ry, rz arc-seconds; s ppm): 0, or -1 (not finite, or a scale ≤ −10⁶ ppm). */
static int helmert_init(helmert_t *h, const double p[7])
{
    for (int i = 0; i < 7; i++)
        if (!isfinite(p[i]))
            return -1;
    if (p[6] <= -1.0e6)
        return -1;
    const double rx = p[3] * ARCSEC_TO_RAD, ry = p[4] * ARCSEC_TO_RAD, rz = p[5] * ARCSEC_TO_RAD;
    h->t[0] = p[0];
    h->t[1] = p[1];
    h->t[2] = p[2];
    h->scale = 1.0 + p[6] * 1e-6;
    const double R[3][3] = {{1.0, -rz, ry}, {rz, 1.0, -rx}, {-ry, rx, 1.0}};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            h->R[i][j] = R[i][j];
    h->present = 1;
    return 0;
}

/* Step 1: geodetic (φ, λ rad, h m) → Cartesian. */
static void to_cartesian(const ell_t *e, double phi, double lam, double h, double v[3])
{
    const double sphi = sin(phi), cphi = cos(phi);
    const double n = e->a / sqrt(1.0 - e->e2 * sphi * sphi);
    v[0] = (n + h) * cphi * cos(lam);
    v[1] = (n + h) * cphi * sin(lam);
    v[2] = (n * (1.0 - e->e2) + h) * sphi;
}

/* Step 4: Cartesian → geodetic (φ, λ rad, h m), Bowring's formula iterated (module doc). */
static void to_geodetic(const ell_t *e, const double v[3], double out[3])
{
    const double p = hypot(v[0], v[1]), ratio = e->b / e->a; /* 1 − f */
    out[1] = atan2(v[1], v[0]);
    if (p == 0.0) {
        out[0] = copysign(90.0 * DEG_TO_RAD, v[2]);
        out[2] = fabs(v[2]) - e->b;
        return;
    }
    double beta = atan2(v[2], ratio * p), phi = beta;
    for (int i = 0; i < 8; i++) {
        const double sb = sin(beta), cb = cos(beta);
        phi = atan2(v[2] + e->ep2 * e->b * sb * sb * sb, p - e->e2 * e->a * cb * cb * cb);
        const double next = atan2(ratio * sin(phi), cos(phi));
        const int done = fabs(next - beta) < 1e-14;
        beta = next;
        if (done)
            break;
    }
    const double sphi = sin(phi);
    out[0] = phi;
    out[2] = p * cos(phi) + v[2] * sphi - e->a * sqrt(1.0 - e->e2 * sphi * sphi);
}

/* Steps 2 and 3. */
static void helmert_forward(const helmert_t *h, double v[3])
{
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = h->t[i] + h->scale * (h->R[i][0] * v[0] + h->R[i][1] * v[1] + h->R[i][2] * v[2]);
    v[0] = r[0];
    v[1] = r[1];
    v[2] = r[2];
}

static void helmert_reverse(const helmert_t *h, double v[3])
{
    const double x = (v[0] - h->t[0]) / h->scale, y = (v[1] - h->t[1]) / h->scale,
                 z = (v[2] - h->t[2]) / h->scale;
    for (int i = 0; i < 3; i++)
        v[i] = h->R[0][i] * x + h->R[1][i] * y + h->R[2][i] * z;
}

/* The whole forward transformation: (lat deg, lon deg, h m) on the source datum -> out on the
 * destination. 0, or -1 where the reference is left to answer (module doc). */
static int shift_fwd(const ShiftObject *S, double lat, double lon, double h, double out[3])
{
    double v[3], g[3];
    if (!isfinite(lat) || !isfinite(lon) || !isfinite(h) || fabs(lat) > 90.0 ||
        fabs(lon * DEG_TO_RAD) > 10.0)
        return -1;
    to_cartesian(&S->src, lat * DEG_TO_RAD, lon * DEG_TO_RAD, h, v);
    if (S->hsrc.present)
        helmert_forward(&S->hsrc, v);
    if (S->hdst.present)
        helmert_reverse(&S->hdst, v);
    to_geodetic(&S->dst, v, g);
    out[0] = g[0] / DEG_TO_RAD;
    out[1] = g[1] / DEG_TO_RAD;
    out[2] = g[2];
    if (!isfinite(out[0]) || !isfinite(out[1]) || !isfinite(out[2]))
        return -1;
    if (fabs(fabs(out[1]) - 180.0) < 1e-9) /* on the antimeridian: ±180° is the rounding's */
        return -1;
    if (fabs(out[0]) > 89.0) /* near a pole λ = atan2(Y, X) of the rounding of X, Y ≈ 0 */
        return -1;
    return 0;
}

static PyObject *triple(const double out[3])
{
    PyObject *t = PyTuple_New(3);
    if (t == NULL)
        return NULL;
    for (int i = 0; i < 3; i++) {
        PyObject *f = PyFloat_FromDouble(out[i]);
        if (f == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, i, f);
    }
    return t;
}

/* ------------------------------------------------------------------ the Shift type */
static PyObject *
shift_vectorcall(PyObject *self, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    ShiftObject *S = (ShiftObject *)self;
    Py_ssize_t nargs = PyVectorcall_NARGS(nargsf);
    double out[3];
    if (kwnames == NULL && nargs == 3 && PyFloat_CheckExact(args[0])
        && PyFloat_CheckExact(args[1]) && PyFloat_CheckExact(args[2])
        && shift_fwd(S, PyFloat_AS_DOUBLE(args[0]), PyFloat_AS_DOUBLE(args[1]),
                     PyFloat_AS_DOUBLE(args[2]), out) == 0)
        return triple(out);
    return PyObject_Vectorcall(S->fallback, args, nargsf, kwnames);
}

PyDoc_STRVAR(forward_doc,
"forward(x, y, z) -> (x, y, z) or None\n\n"
"The shift computed here (floats: lat deg, lon deg, h m on the source datum -> the same on\n"
"the destination), or None where this kernel declines (the reference then answers). For the\n"
"first-use check and the tests.");

static PyObject *shift_forward(PyObject *self, PyObject *args)
{
    double x, y, z, out[3];
    if (!PyArg_ParseTuple(args, "ddd:forward", &x, &y, &z))
        return NULL;
    if (shift_fwd((ShiftObject *)self, x, y, z, out) < 0)
        Py_RETURN_NONE;
    return triple(out);
}

static PyObject *shift_get_fallback(PyObject *self, void *closure)
{
    (void)closure;
    return Py_NewRef(((ShiftObject *)self)->fallback);
}

static int shift_traverse(PyObject *self, visitproc visit, void *arg)
{
    Py_VISIT(((ShiftObject *)self)->fallback);
    return 0;
}

static int shift_clear(PyObject *self)
{
    Py_CLEAR(((ShiftObject *)self)->fallback);
    return 0;
}

static void shift_dealloc(PyObject *self)
{
    PyObject_GC_UnTrack(self);
    shift_clear(self);
    Py_TYPE(self)->tp_free(self);
}

/* a helmert's 7 numbers (x, y, z m; rx, ry, rz arc-seconds; s ppm) or None */
static int helmert_arg(PyObject *o, helmert_t *h)
{
    double p[7];
    h->present = 0;
    if (o == Py_None)
        return 0;
    if (!PyTuple_Check(o) || PyTuple_GET_SIZE(o) != 7) {
        PyErr_SetString(PyExc_TypeError, "a helmert is None or 7 floats");
        return -1;
    }
    for (int i = 0; i < 7; i++) {
        p[i] = PyFloat_AsDouble(PyTuple_GET_ITEM(o, i));
        if (p[i] == -1.0 && PyErr_Occurred())
            return -1;
    }
    if (helmert_init(h, p) < 0) {
        PyErr_SetString(PyExc_ValueError, "helmert parameters out of range");
        return -1;
    }
    return 0;
}

static PyObject *shift_new(PyTypeObject *type, PyObject *args, PyObject *kwds)
{
    PyObject *fallback, *h_src, *h_dst;
    double a_src, rf_src, a_dst, rf_dst;
    ShiftObject *S;
    static char *kwlist[] = {"fallback", "a_src", "rf_src", "helmert_src", "a_dst", "rf_dst",
                             "helmert_dst", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OddOddO:Shift", kwlist, &fallback, &a_src,
                                     &rf_src, &h_src, &a_dst, &rf_dst, &h_dst))
        return NULL;
    if (!PyCallable_Check(fallback)) {
        PyErr_SetString(PyExc_TypeError, "fallback must be callable");
        return NULL;
    }
    S = (ShiftObject *)type->tp_alloc(type, 0);
    if (S == NULL)
        return NULL;
    S->vectorcall = shift_vectorcall;
    S->fallback = Py_NewRef(fallback);
    if (ell_init(&S->src, a_src, rf_src) < 0 || ell_init(&S->dst, a_dst, rf_dst) < 0) {
        Py_DECREF(S);
        PyErr_SetString(PyExc_ValueError, "an ellipsoid out of range");
        return NULL;
    }
    if (helmert_arg(h_src, &S->hsrc) < 0 || helmert_arg(h_dst, &S->hdst) < 0) {
        Py_DECREF(S);
        return NULL;
    }
    return (PyObject *)S;
}

static PyMethodDef shift_methods[] = {
    {"forward", shift_forward, METH_VARARGS, forward_doc},
    {NULL, NULL, 0, NULL}
};

static PyGetSetDef shift_getset[] = {
    {"fallback", shift_get_fallback, NULL, "the reference's call for what this declines", NULL},
    {NULL, NULL, NULL, NULL, NULL}
};

PyDoc_STRVAR(shift_doc,
"Shift(fallback, a_src, rf_src, helmert_src, a_dst, rf_dst, helmert_dst)\n\n"
"DatumShift(src, dst).transform compiled (module doc): (lat deg, lon deg, h m) -> the same\n"
"on the destination; ``fallback`` (the reference's transform) answers what it does not cover.\n"
"rf 0.0: a sphere; a helmert: None (omitted step) or (x, y, z m, rx, ry, rz arcsec, s ppm).");

static PyTypeObject ShiftType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "engine.native.datum.Shift",
    .tp_basicsize = sizeof(ShiftObject),
    .tp_dealloc = shift_dealloc,
    .tp_vectorcall_offset = offsetof(ShiftObject, vectorcall),
    .tp_call = PyVectorcall_Call,
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_doc = shift_doc,
    .tp_traverse = shift_traverse,
    .tp_clear = shift_clear,
    .tp_methods = shift_methods,
    .tp_getset = shift_getset,
    .tp_new = shift_new,
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "engine.native.datum",
    "DatumShift's geocentric datum shifts, compiled (module doc of datum.c).", -1,
    NULL,
};

PyMODINIT_FUNC PyInit_datum(void)
{
    PyObject *m;
    if (PyType_Ready(&ShiftType) < 0)
        return NULL;
    m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0
        || PyModule_AddObjectRef(m, "Shift", (PyObject *)&ShiftType) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
