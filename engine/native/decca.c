/* Decca hyperbolic lanes: the lane model, the ship -> station azimuths, the LEF, the fix's
 * Decca rows and VCV, compiled (engine.native.decca).
 *
 * Every function does the operations of the Python it replaces (engine/systems/decca.py:
 * _lane_model, _lef, decca_geometry, DeccaObservations.linearise, _LaneAt._lanes;
 * engine/geodesy/ellipsoidal.py: GeodesicSolver.forward_azimuths_rad) in the same order, so the
 * results agree to the engine's tolerance contract (docs/PERFORMANCE.md;
 * tests/native/test_decca.py):
 *   - Python's math.sin/cos/atan2/radians and float ** 2 are glibc's sin/cos/atan2/pow, called
 *     through volatile pointers (gcc may neither fold pow(x, 2.0) into x*x nor merge sin and
 *     cos into sincos), with CPython's error rules (math domain error, float division by zero,
 *     overflow of **);
 *   - math.hypot is CPython's own (correctly rounded) function, called through its object;
 *   - float % is CPython's float_rem (fmod, then the sign of the divisor);
 *   - the geodesic inverse is Vincenty's (section "the geodesic inverse"), pyproj's public
 *     Geod.inv where that is not used;
 *   - lane_sigma's row @ cov @ row: the kernel's own 2×2 products (uvn_linalg.h).
 * Glue of the systems' stage: geometry_new makes decca_geometry's
 * DeccaGeometry with its arrays in one call, linearise_at takes a Point's latlon from the
 * tmgrid kernel's inverse before linearise, gps_rows writes engine.systems.gps's two
 * coordinate rows (the same floats as their Python; tests/native/test_decca_glue.py).
 * Functions given arguments of other types than the Python fast path sees (not floats, not
 * tuples/lists of the expected lengths) return NotImplemented: the caller then runs its Python.
 */
#include "uvn_numpy.h" /* numpy arrays through numpy's C API (PY_SSIZE_T_CLEAN, Python.h) */
#include "uvn_linalg.h" /* small-matrix products (lane_sigma) */
#include <math.h>
#include <errno.h>
#include <string.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

/* ------------------------------------------------------------------ libm, CPython's rules */
static double (*volatile v_sin)(double) = sin;
static double (*volatile v_cos)(double) = cos;
static double (*volatile v_atan2)(double, double) = atan2;
static double (*volatile v_pow)(double, double) = pow;
static double (*volatile v_fmod)(double, double) = fmod;

static const double DEG_TO_RAD = Py_MATH_PI / 180.0; /* CPython mathmodule's degToRad */
static const double TWO_PI = 2.0 * Py_MATH_PI;        /* decca._TWO_PI */
static const double HALF_PI = Py_MATH_PI / 2.0;       /* decca._HALF_PI */

static PyObject *math_hypot = NULL; /* math.hypot (CPython's vector_norm) */
static PyObject *math_atan2 = NULL; /* math.atan2 for non-finite arguments (its special cases) */

static int domain_error(void)
{
    PyErr_SetString(PyExc_ValueError, "math domain error");
    return -1;
}

static int zero_division(void)
{
    PyErr_SetString(PyExc_ZeroDivisionError, "float division by zero");
    return -1;
}

/* math.sin / math.cos (math_1, can_overflow 0): NaN from a non-NaN argument or an infinite
 * result from a finite one is a domain error. */
static int py_sin(double x, double *out)
{
    double r = v_sin(x);
    if ((isnan(r) && !isnan(x)) || (isinf(r) && isfinite(x)))
        return domain_error();
    *out = r;
    return 0;
}

static int py_cos(double x, double *out)
{
    double r = v_cos(x);
    if ((isnan(r) && !isnan(x)) || (isinf(r) && isfinite(x)))
        return domain_error();
    *out = r;
    return 0;
}

/* a / b as Python's float division (ZeroDivisionError for b == 0). */
#define PYDIV(out, a, b)                  \
    do {                                  \
        double den_ = (b);                \
        if (den_ == 0.0)                  \
            return zero_division();       \
        (out) = (a) / den_;               \
    } while (0)

/* Python's float % (float_rem) for a non-zero divisor w. */
static double py_mod(double v, double w)
{
    double mod = v_fmod(v, w);
    if (mod) {
        if ((w < 0) != (mod < 0))
            mod += w;
    }
    else {
        mod = copysign(0.0, w);
    }
    return mod;
}

/* x ** 2 on a float (float_pow with iw = 2.0). */
static int py_square(double iv, double *out)
{
    double ix;
    if (isnan(iv)) {
        *out = iv;
        return 0;
    }
    if (isinf(iv)) {
        *out = fabs(iv);
        return 0;
    }
    if (iv == 0.0) {
        *out = 0.0;
        return 0;
    }
    if (iv == 1.0) {
        *out = 1.0;
        return 0;
    }
    if (iv < 0.0)
        iv = -iv; /* even integer power: not negated */
    errno = 0;
    ix = v_pow(iv, 2.0);
    if (isinf(ix)) {
        errno = ERANGE;
        PyErr_SetFromErrno(PyExc_OverflowError);
        return -1;
    }
    *out = ix;
    return 0;
}

/* math.hypot(a, b) through the function object. */
static int py_hypot(double a, double b, double *out)
{
    PyObject *args[2], *r;
    args[0] = PyFloat_FromDouble(a);
    if (args[0] == NULL)
        return -1;
    args[1] = PyFloat_FromDouble(b);
    if (args[1] == NULL) {
        Py_DECREF(args[0]);
        return -1;
    }
    r = PyObject_Vectorcall(math_hypot, args, 2, NULL);
    Py_DECREF(args[0]);
    Py_DECREF(args[1]);
    if (r == NULL)
        return -1;
    *out = PyFloat_AS_DOUBLE(r);
    Py_DECREF(r);
    return 0;
}

/* math.atan2(y, x): glibc's atan2 for finite arguments (CPython's m_atan2 only special-cases
 * NaN, infinities and y == 0, where C99's atan2 gives the same); math.atan2 otherwise. */
static int py_atan2(double y, double x, double *out)
{
    PyObject *args[2], *r;
    if (isfinite(x) && isfinite(y) && y != 0.0) {
        *out = v_atan2(y, x);
        return 0;
    }
    args[0] = PyFloat_FromDouble(y);
    if (args[0] == NULL)
        return -1;
    args[1] = PyFloat_FromDouble(x);
    if (args[1] == NULL) {
        Py_DECREF(args[0]);
        return -1;
    }
    r = PyObject_Vectorcall(math_atan2, args, 2, NULL);
    Py_DECREF(args[0]);
    Py_DECREF(args[1]);
    if (r == NULL)
        return -1;
    *out = PyFloat_AS_DOUBLE(r);
    Py_DECREF(r);
    return 0;
}

/* ------------------------------------------------------------------ the geodesic inverse */
/* The ship → station azimuths on the chain's ellipsoid: Vincenty's iteration on the longitude ω
 * of the auxiliary sphere (T. Vincenty, Survey Review 23(176):88–93, 1975, eqs. 13–14 and the
 * azimuth equations 20), with the longitude and distance integrals (Karney 2013, J. Geodesy
 * 87:43–55, eqs. 7–8) taken by Gauss–Legendre quadrature instead of Vincenty's truncated
 * series, so the result is the exact geodesic to rounding, as Karney's algorithm (pyproj's
 * Geod, the pure path) gives it. Where this is not used — lines shorter than 1 km (where the
 * azimuth moves by more than 1e-9° for a last-bit change of an end point, so the pure path's
 * own answer is taken), lines longer than σ = 0.5 rad (~3200 km), a latitude within 1e-4° of a pole, no convergence —
 * pyproj's public Geod(a=, f=).inv answers (made on first need, kept on the object). */
typedef struct {
    PyObject_HEAD
    double a, f;
    PyObject *geod; /* pyproj.Geod(a=a, f=f), made on first need, or NULL */
} GeodesicObject;

static PyTypeObject GeodesicType;

static int geodesic_init(GeodesicObject *self, PyObject *args, PyObject *kwds)
{
    double a, f;
    if (!PyArg_ParseTuple(args, "dd:Geodesic", &a, &f))
        return -1;
    if (!(a > 0.0) || !isfinite(a) || !(f >= 0.0 && f < 0.1)) {
        PyErr_SetString(PyExc_ValueError, "Geodesic: an ellipsoid (a > 0, 0 <= f < 0.1)");
        return -1;
    }
    self->a = a;
    self->f = f;
    Py_CLEAR(self->geod);
    return 0;
}

static void geodesic_dealloc(GeodesicObject *self)
{
    Py_CLEAR(self->geod);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

/* ∫ from s0 to s0 + ds of fn(s) ds by Gauss–Legendre (5 nodes on each of two halves): exact to
 * rounding for the smooth integrands below on arcs up to 0.5 rad. */
static double gauss(double (*fn)(double, double, double), double s0, double ds, double f,
                    double k2)
{
    static const double x[5] = {-0.9061798459386640, -0.5384693101056831, 0.0,
                                0.5384693101056831, 0.9061798459386640};
    static const double w[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                                0.4786286704993665, 0.2369268850561891};
    const double h = ds / 4.0; /* half of each half */
    double sum = 0.0;
    for (int part = 0; part < 2; part++) {
        const double mid = s0 + (2 * part + 1) * h;
        for (int i = 0; i < 5; i++)
            sum += w[i] * fn(mid + h * x[i], f, k2);
    }
    return sum * h;
}

/* The integrands of the geodesic on the auxiliary sphere (Karney 2013, J. Geodesy 87:43–55,
 * eqs. 7 and 8): the distance s/b = ∫ √(1 + k² sin²σ) dσ and the longitude
 * λ = ω − f sin α₀ ∫ (2 − f) / (1 + (1 − f) √(1 + k² sin²σ)) dσ, k² = e'² cos²α₀. */
static double arc_length(double sg, double f, double k2)
{
    (void)f;
    const double t = sin(sg);
    return sqrt(1.0 + k2 * t * t);
}

static double lon_term(double sg, double f, double k2)
{
    const double t = sin(sg);
    return (2.0 - f) / (1.0 + (1.0 - f) * sqrt(1.0 + k2 * t * t));
}

/* Vincenty's iteration with the exact integrals: 0 with the forward azimuths at 1 and at 2
 * (degrees, (-180, 180]) and the distance (m), or -1 where it is not used (see above). */
static int vincenty(const GeodesicObject *g, double lon1, double lat1, double lon2, double lat2,
                    double *az1, double *az2, double *s12)
{
    const double f = g->f, a = g->a, b = a * (1.0 - f), ep2 = f * (2.0 - f) / ((1.0 - f) * (1.0 - f));
    if (!isfinite(lon1) || !isfinite(lat1) || !isfinite(lon2) || !isfinite(lat2) ||
        fabs(lat1) > 89.9999 || fabs(lat2) > 89.9999)
        return -1;
    const double L = remainder(lon2 - lon1, 360.0) * DEG_TO_RAD;
    const double U1 = atan((1.0 - f) * tan(lat1 * DEG_TO_RAD)),
                 U2 = atan((1.0 - f) * tan(lat2 * DEG_TO_RAD));
    const double su1 = sin(U1), cu1 = cos(U1), su2 = sin(U2), cu2 = cos(U2);
    double om = L, sl = 0, cl = 0, ss = 0, cs = 0, sig = 0, sig1 = 0, k2 = 0;
    int it = 0;
    for (; it < 100; it++) {
        sl = sin(om);
        cl = cos(om);
        const double ca1 = cu1 * su2 - su1 * cu2 * cl; /* ss cos α₁ */
        ss = hypot(cu2 * sl, ca1);
        if (ss < 1e-12) /* coincident (or antipodal) points: the azimuth is a convention */
            return -1;
        cs = su1 * su2 + cu1 * cu2 * cl;
        sig = atan2(ss, cs);
        if (sig > 0.5 || sig * b < 1000.0) /* long, or short: ill-conditioned azimuth */
            return -1;
        const double sa = cu1 * cu2 * sl / ss; /* sin α₀ */
        k2 = ep2 * (1.0 - sa * sa);
        sig1 = atan2(su1 * ss, cu1 * ca1); /* tan σ₁ = tan β₁ / cos α₁ */
        const double prev = om;
        om = L + f * sa * gauss(lon_term, sig1, sig, f, k2);
        if (fabs(om - prev) < 1e-15)
            break;
    }
    if (it == 100)
        return -1;
    sl = sin(om);
    cl = cos(om);
    *az1 = atan2(cu2 * sl, cu1 * su2 - su1 * cu2 * cl) / DEG_TO_RAD;
    *az2 = atan2(cu1 * sl, -su1 * cu2 + cu1 * su2 * cl) / DEG_TO_RAD;
    *s12 = b * gauss(arc_length, sig1, sig, f, k2);
    return 0;
}

/* pyproj's Geod(a=, f=).inv(lon1, lat1, lon2, lat2, return_back_azimuth=False): 0 with (az1,
 * az2, s12), the forward azimuths at 1 and 2, or -1 (exception set). */
static int geod_fallback(GeodesicObject *g, double lon1, double lat1, double lon2, double lat2,
                         double *az1, double *az2, double *s12)
{
    if (g->geod == NULL) {
        PyObject *mod = PyImport_ImportModule("pyproj");
        PyObject *cls = mod == NULL ? NULL : PyObject_GetAttrString(mod, "Geod");
        Py_XDECREF(mod);
        if (cls == NULL)
            return -1;
        PyObject *kw = Py_BuildValue("{s:d,s:d}", "a", g->a, "f", g->f);
        PyObject *empty = PyTuple_New(0);
        if (kw != NULL && empty != NULL)
            g->geod = PyObject_Call(cls, empty, kw);
        Py_XDECREF(kw);
        Py_XDECREF(empty);
        Py_DECREF(cls);
        if (g->geod == NULL)
            return -1;
    }
    PyObject *inv = PyObject_GetAttrString(g->geod, "inv");
    PyObject *args = inv == NULL ? NULL : Py_BuildValue("(dddd)", lon1, lat1, lon2, lat2);
    PyObject *kw = args == NULL ? NULL : Py_BuildValue("{s:O}", "return_back_azimuth", Py_False);
    PyObject *r = kw == NULL ? NULL : PyObject_Call(inv, args, kw);
    Py_XDECREF(inv);
    Py_XDECREF(args);
    Py_XDECREF(kw);
    if (r == NULL)
        return -1;
    int ok = PyArg_ParseTuple(r, "ddd", az1, az2, s12);
    Py_DECREF(r);
    return ok ? 0 : -1;
}

/* The forward azimuth 1 → 2 (degrees, (-180, 180]); NaN with an exception set on a failure of
 * the fallback. */
static double geod_az12(const GeodesicObject *g, double lon1, double lat1, double lon2,
                        double lat2)
{
    double s12, azi1, azi2;
    if (vincenty(g, lon1, lat1, lon2, lat2, &azi1, &azi2, &s12) == 0)
        return azi1;
    if (geod_fallback((GeodesicObject *)g, lon1, lat1, lon2, lat2, &azi1, &azi2, &s12) < 0)
        return NAN;
    return azi1;
}

/* Float value of a Python float or int (what Geod._inv_point accepts), -1 with TypeError. */
static int inv_arg(PyObject *o, double *out)
{
    if (PyFloat_CheckExact(o)) {
        *out = PyFloat_AS_DOUBLE(o);
        return 0;
    }
    *out = PyFloat_AsDouble(o);
    if (*out == -1.0 && PyErr_Occurred())
        return -1;
    if (!PyFloat_Check(o) && !PyLong_Check(o)) {
        PyErr_SetString(PyExc_TypeError, "Scalar input is required for point based functions");
        return -1;
    }
    return 0;
}

/* forward_azimuths_rad(lat1, lon1, points): [radians(az12 % 360.0) for lat2, lon2 in points]
 * (GeodesicSolver.forward_azimuths_rad). */
static PyObject *geodesic_forward_azimuths(GeodesicObject *self, PyObject *const *args,
                                           Py_ssize_t nargs, int rad)
{
    double lat1, lon1, lat2, lon2, az;
    PyObject *seq, *out = NULL;
    Py_ssize_t n, i;
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "forward_azimuths needs (lat1, lon1, points)");
        return NULL;
    }
    seq = PySequence_Fast(args[2], "points must be a sequence of (lat, lon)");
    if (seq == NULL)
        return NULL;
    n = PySequence_Fast_GET_SIZE(seq);
    if (n > 0 && (inv_arg(args[1], &lon1) < 0 || inv_arg(args[0], &lat1) < 0)) {
        Py_DECREF(seq);
        return NULL;
    }
    out = PyList_New(n);
    if (out == NULL)
        goto fail;
    for (i = 0; i < n; i++) {
        PyObject *pt = PySequence_Fast_GET_ITEM(seq, i), *v;
        if (!PyTuple_CheckExact(pt) || PyTuple_GET_SIZE(pt) != 2) {
            PyObject *t = PySequence_Tuple(pt);
            if (t == NULL)
                goto fail;
            if (PyTuple_GET_SIZE(t) != 2) {
                Py_DECREF(t);
                PyErr_SetString(PyExc_ValueError, "a point is (lat, lon)");
                goto fail;
            }
            if (inv_arg(PyTuple_GET_ITEM(t, 1), &lon2) < 0
                || inv_arg(PyTuple_GET_ITEM(t, 0), &lat2) < 0) {
                Py_DECREF(t);
                goto fail;
            }
            Py_DECREF(t);
        }
        else if (inv_arg(PyTuple_GET_ITEM(pt, 1), &lon2) < 0
                 || inv_arg(PyTuple_GET_ITEM(pt, 0), &lat2) < 0) {
            goto fail;
        }
        az = py_mod(geod_az12(self, lon1, lat1, lon2, lat2), 360.0);
        if (PyErr_Occurred())
            goto fail;
        v = PyFloat_FromDouble(rad ? az * DEG_TO_RAD : az);
        if (v == NULL)
            goto fail;
        PyList_SET_ITEM(out, i, v);
    }
    Py_DECREF(seq);
    return out;
fail:
    Py_XDECREF(out);
    Py_DECREF(seq);
    return NULL;
}

static PyObject *geodesic_forward_azimuths_rad(GeodesicObject *self, PyObject *const *args,
                                               Py_ssize_t nargs)
{
    return geodesic_forward_azimuths(self, args, nargs, 1);
}

static PyObject *geodesic_forward_azimuths_deg(GeodesicObject *self, PyObject *const *args,
                                               Py_ssize_t nargs)
{
    return geodesic_forward_azimuths(self, args, nargs, 0);
}

/* inverse_point(lon1, lat1, lon2, lat2) -> (az12, az2, s12): the forward azimuths at 1 and at
 * 2 (degrees) and the distance (m), as geod_inverse gives them, for the tests. */
static PyObject *geodesic_inverse_point(GeodesicObject *self, PyObject *args)
{
    double lon1, lat1, lon2, lat2, s12, azi1, azi2;
    if (!PyArg_ParseTuple(args, "dddd:inverse_point", &lon1, &lat1, &lon2, &lat2))
        return NULL;
    if (vincenty(self, lon1, lat1, lon2, lat2, &azi1, &azi2, &s12) < 0 &&
        geod_fallback(self, lon1, lat1, lon2, lat2, &azi1, &azi2, &s12) < 0)
        return NULL;
    return Py_BuildValue("(ddd)", azi1, azi2, s12);
}

/* own_point(lon1, lat1, lon2, lat2) -> (az12, az2, s12) computed here, or None where the kernel
 * leaves the line to pyproj (see above): for the first-use check, which must not import
 * pyproj. */
static PyObject *geodesic_own_point(GeodesicObject *self, PyObject *args)
{
    double lon1, lat1, lon2, lat2, s12, azi1, azi2;
    if (!PyArg_ParseTuple(args, "dddd:own_point", &lon1, &lat1, &lon2, &lat2))
        return NULL;
    if (vincenty(self, lon1, lat1, lon2, lat2, &azi1, &azi2, &s12) < 0)
        Py_RETURN_NONE;
    return Py_BuildValue("(ddd)", azi1, azi2, s12);
}

static PyMethodDef geodesic_methods[] = {
    {"own_point", (PyCFunction)geodesic_own_point, METH_VARARGS,
     "(az12, az2, s12) computed by the kernel, or None where pyproj answers."},
    {"forward_azimuths_rad", (PyCFunction)(void (*)(void))geodesic_forward_azimuths_rad,
     METH_FASTCALL, "GeodesicSolver.forward_azimuths_rad (radians, [0, 2pi])."},
    {"forward_azimuths_deg", (PyCFunction)(void (*)(void))geodesic_forward_azimuths_deg,
     METH_FASTCALL, "GeodesicSolver.forward_azimuths_deg (degrees, [0, 360))."},
    {"inverse_point", (PyCFunction)geodesic_inverse_point, METH_VARARGS,
     "(az12, az2, s12): Vincenty's inverse (degrees, metres), pyproj's where not used."},
    {NULL, NULL, 0, NULL},
};

static PyObject *geodesic_get_a(GeodesicObject *self, void *c) { return PyFloat_FromDouble(self->a); }
static PyObject *geodesic_get_f(GeodesicObject *self, void *c) { return PyFloat_FromDouble(self->f); }

static PyGetSetDef geodesic_getset[] = {
    {"a", (getter)geodesic_get_a, NULL, "semi-major axis (m)", NULL},
    {"f", (getter)geodesic_get_f, NULL, "flattening", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject GeodesicType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "engine.native.decca.Geodesic",
    .tp_basicsize = sizeof(GeodesicObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "Geodesic(a, f): the inverse problem on the ellipsoid (a m, flattening f).",
    .tp_dealloc = (destructor)geodesic_dealloc,
    .tp_new = PyType_GenericNew,
    .tp_init = (initproc)geodesic_init,
    .tp_methods = geodesic_methods,
    .tp_getset = geodesic_getset,
};

/* ------------------------------------------------------------------ the chain's scalars */
typedef struct {
    double st[4][4];   /* per station (x, y, x^2, lat) */
    double latlon[4][2];
    double lam[3], base[3], kmin[3], sky[3];
    double e2, num;
} chain_t;

/* A float of a tuple item (exact float or subclass), else 1 (not the fast path's type). */
static int item_float(PyObject *t, Py_ssize_t i, double *out)
{
    PyObject *o = PyTuple_GET_ITEM(t, i);
    if (!PyFloat_Check(o))
        return 1;
    *out = PyFloat_AS_DOUBLE(o);
    return 0;
}

static int floats_of(PyObject *t, Py_ssize_t n, double *out)
{
    if (!PyTuple_Check(t) || PyTuple_GET_SIZE(t) != n)
        return 1;
    for (Py_ssize_t i = 0; i < n; i++)
        if (item_float(t, i, out + i))
            return 1;
    return 0;
}

static int read_chain_items(PyObject *sc, chain_t *c);

/* The last chain read (a strong reference, so its address is not reused while it is kept) and
 * its numbers: a tuple of tuples of floats cannot change, so the same object has the same
 * numbers (a run reads one placed chain several times a cycle). */
static PyObject *chain_key = NULL;
static chain_t chain_last;

/* _ChainScalars (xy, latlon, wavelength, baseline, min_lanes, stations, e2, rm2_numerator,
 * baseline_sky) -> chain_t; 1 where it is not of that form. */
static int read_chain(PyObject *sc, chain_t *c)
{
    if (sc == chain_key) {
        *c = chain_last;
        return 0;
    }
    if (read_chain_items(sc, c))
        return 1;
    Py_INCREF(sc);
    Py_XSETREF(chain_key, sc);
    chain_last = *c;
    return 0;
}

static int read_chain_items(PyObject *sc, chain_t *c)
{
    PyObject *lst, *o;
    if (!PyTuple_Check(sc) || PyTuple_GET_SIZE(sc) != 9)
        return 1;
    lst = PyTuple_GET_ITEM(sc, 5);
    if (!PyTuple_Check(lst) || PyTuple_GET_SIZE(lst) != 4)
        return 1;
    for (int s = 0; s < 4; s++)
        if (floats_of(PyTuple_GET_ITEM(lst, s), 4, c->st[s]))
            return 1;
    lst = PyTuple_GET_ITEM(sc, 1);
    if (!PyTuple_Check(lst) || PyTuple_GET_SIZE(lst) != 4)
        return 1;
    for (int s = 0; s < 4; s++)
        if (floats_of(PyTuple_GET_ITEM(lst, s), 2, c->latlon[s]))
            return 1;
    if (floats_of(PyTuple_GET_ITEM(sc, 2), 3, c->lam) || floats_of(PyTuple_GET_ITEM(sc, 3), 3, c->base)
        || floats_of(PyTuple_GET_ITEM(sc, 4), 3, c->kmin)
        || floats_of(PyTuple_GET_ITEM(sc, 8), 3, c->sky))
        return 1;
    o = PyTuple_GET_ITEM(sc, 6);
    if (!PyFloat_Check(o))
        return 1;
    c->e2 = PyFloat_AS_DOUBLE(o);
    o = PyTuple_GET_ITEM(sc, 7);
    if (!PyFloat_Check(o))
        return 1;
    c->num = PyFloat_AS_DOUBLE(o);
    return 0;
}

static int arg_float(PyObject *o, double *out)
{
    if (!PyFloat_Check(o))
        return 1;
    *out = PyFloat_AS_DOUBLE(o);
    return 0;
}

/* ------------------------------------------------------------------ the lane model */
typedef struct {
    double dist[4], n_calc[3], row_x[3], row_y[3];
} lanes_t;

/* decca._lane_model_py, the same operations in the same order. */
static int lane_model(const chain_t *c, double x_m, double y_m, double lat0, lanes_t *o)
{
    double e2 = c->e2, num = c->num;
    double xx = x_m * x_m, two_x = 2.0 * x_m;
    double dxp[4], dyp[4];
    for (int i = 0; i < 4; i++) {
        double xs = c->st[i][0], ys = c->st[i][1], xs2 = c->st[i][2], slat = c->st[i][3];
        double s, w2, rm2, dx, dy, chord, lsf, lc, t;
        if (py_sin((0.5 * (lat0 + slat)) * DEG_TO_RAD, &s) < 0)
            return -1;
        w2 = 1.0 - e2 * s * s;
        PYDIV(rm2, num, w2 * w2);
        dx = x_m - xs;
        dy = y_m - ys;
        if (py_hypot(dx, dy, &chord) < 0)
            return -1;
        PYDIV(t, xx + x_m * xs + xs2, 6.0 * rm2);
        lsf = 1.0 + t;
        lc = lsf * chord;
        PYDIV(o->dist[i], chord, lsf);
        {
            double a, b;
            PYDIV(a, dx, lc);
            PYDIV(b, chord * (two_x + xs), lsf * lsf * 6.0 * rm2);
            dxp[i] = a - b;
        }
        PYDIV(dyp[i], dy, lc);
    }
    {
        const double *l = c->lam, *b = c->base, *k = c->kmin, *d = o->dist;
        for (int j = 0; j < 3; j++) {
            double t;
            PYDIV(t, d[0] - d[j + 1] + b[j], l[j]);
            o->n_calc[j] = t + k[j];
        }
        for (int j = 0; j < 3; j++)
            PYDIV(o->row_x[j], dxp[0] - dxp[j + 1], l[j]);
        for (int j = 0; j < 3; j++)
            PYDIV(o->row_y[j], dyp[0] - dyp[j + 1], l[j]);
    }
    return 0;
}

/* decca._azimuths_rad through the compiled geodesic. */
static void azimuths(const GeodesicObject *g, const chain_t *c, double lat0, double lon0,
                     double az[4])
{
    for (int i = 0; i < 4; i++)
        az[i] = py_mod(geod_az12(g, lon0, lat0, c->latlon[i][1], c->latlon[i][0]), 360.0)
                * DEG_TO_RAD;
}

/* decca._lef_py. */
static int lef_of(const double az[4], double lef[3])
{
    double az0 = az[0];
    for (int s = 1; s < 4; s++) {
        double gamma = py_mod(fabs(az[s] - az0), TWO_PI), sn;
        if (gamma > Py_MATH_PI)
            gamma = TWO_PI - gamma;
        if (py_sin(gamma / 2.0, &sn) < 0)
            return -1;
        PYDIV(lef[s - 1], 1.0, sn);
    }
    return 0;
}

static PyObject *list_of(const double *v, Py_ssize_t n)
{
    PyObject *out = PyList_New(n);
    if (out == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *f = PyFloat_FromDouble(v[i]);
        if (f == NULL) {
            Py_DECREF(out);
            return NULL;
        }
        PyList_SET_ITEM(out, i, f);
    }
    return out;
}

static int check_geodesic(PyObject *o)
{
    return !PyObject_TypeCheck(o, &GeodesicType);
}

/* decca_geometry's numbers at (x, y) of geodetic (lat0, lon0): d_master, az_master and the
 * 24 per-pattern floats in the order of the Python's ``block`` list. 0, -1 (error set). */
static int geometry_numbers(const chain_t *c, const GeodesicObject *g, double x, double y,
                            double lat0, double lon0, double *d_master, double *az_master,
                            double block[24])
{
    double az[4], lef[3], s0, c0;
    lanes_t o;
    if (lane_model(c, x, y, lat0, &o) < 0)
        return -1;
    azimuths(g, c, lat0, lon0, az);
    if (PyErr_Occurred() || lef_of(az, lef) < 0)
        return -1;
    for (int j = 0; j < 3; j++) {
        block[j] = o.dist[j + 1];
        block[3 + j] = py_mod(az[j + 1], TWO_PI);
        block[6 + j] = lef[j];
        block[9 + j] = c->lam[j] * lef[j] / 2.0;
    }
    if (py_sin(az[0], &s0) < 0 || py_cos(az[0], &c0) < 0)
        return -1;
    for (int j = 0; j < 3; j++) {
        double sa, ca, t;
        if (py_sin(az[j + 1], &sa) < 0 || py_cos(az[j + 1], &ca) < 0
            || py_atan2(-s0 + sa, -c0 + ca, &t) < 0)
            return -1;
        block[12 + j] = py_mod(t + HALF_PI, TWO_PI);
    }
    for (int j = 0; j < 3; j++) {
        block[15 + j] = o.n_calc[j];
        block[18 + 2 * j] = o.row_x[j];
        block[19 + 2 * j] = o.row_y[j];
    }
    *d_master = o.dist[0];
    *az_master = py_mod(az[0], TWO_PI);
    return 0;
}

/* geometry(sc, geodesic, x, y, lat0, lon0) -> (d_master, az_master, block): decca_geometry's
 * numbers, ``block`` its 24 per-pattern floats in the order of the Python's ``block`` list. */
static PyObject *py_geometry(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    double x, y, lat0, lon0, block[24], dm, azm;
    if (nargs != 6 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[2], &x) || arg_float(args[3], &y) || arg_float(args[4], &lat0)
        || arg_float(args[5], &lon0))
        Py_RETURN_NOTIMPLEMENTED;
    if (geometry_numbers(&c, (GeodesicObject *)args[1], x, y, lat0, lon0, &dm, &azm, block) < 0)
        return NULL;
    return Py_BuildValue("(ddN)", dm, azm, list_of(block, 24));
}

/* geometry_new(sc, geodesic, x, y, lat0, lon0, make, baseline_m) -> make(d_master, az_master,
 * d_slave, az_slave, baseline_m, lef, metres_per_lane, lop_azimuth_rad, n_calc, row): the
 * DeccaGeometry of decca_geometry in one call, its arrays (3,) and row (3, 2) float64 made here
 * (uvn_numpy.h) with the values the Python's block views hold. NotImplemented as geometry. */
static PyObject *py_geometry_new(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    double x, y, lat0, lon0, block[24], dm, azm, *data;
    PyObject *v[10] = {NULL}, *out = NULL;
    if (nargs != 8 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[2], &x) || arg_float(args[3], &y) || arg_float(args[4], &lat0)
        || arg_float(args[5], &lon0))
        Py_RETURN_NOTIMPLEMENTED;
    if (geometry_numbers(&c, (GeodesicObject *)args[1], x, y, lat0, lon0, &dm, &azm, block) < 0)
        return NULL;
    if (np_ready() < 0)
        return NULL;
    v[0] = PyFloat_FromDouble(dm);
    v[1] = PyFloat_FromDouble(azm);
    if (v[0] == NULL || v[1] == NULL)
        goto done;
    v[4] = Py_NewRef(args[7]);
    {
        /* d_slave, az_slave, lef, metres_per_lane, lop_azimuth_rad, n_calc: block[3i:3i+3] */
        static const int slot[6] = {2, 3, 5, 6, 7, 8};
        for (int i = 0; i < 6; i++) {
            v[slot[i]] = new_array(3, 0, 1, &data);
            if (v[slot[i]] == NULL)
                goto done;
            memcpy(data, block + 3 * i, 3 * sizeof(double));
        }
    }
    v[9] = new_array(3, 2, 2, &data);
    if (v[9] == NULL)
        goto done;
    memcpy(data, block + 18, 6 * sizeof(double));
    out = PyObject_Vectorcall(args[6], v, 10, NULL);
done:
    for (int i = 0; i < 10; i++)
        Py_XDECREF(v[i]);
    return out;
}

/* Where the LEF of _LaneAt._lanes cannot raise, so its four geodesics need not be computed.
 * The LEF 1/sin(gamma/2) raises only for gamma == 0 (ship -> master and ship -> slave azimuths
 * equal to the bit; NaN azimuths give a NaN LEF, no error). On the TM grid the geodetic azimuth
 * of a station is its chord bearing from the ship plus the convergence at the ship (the same
 * for every station) plus the arc-to-chord term (t - T), at most |dy| |2 x1 + x2| / (6 rho nu)
 * to first order. With the ship and every station within LEF_SAFE_X_M of the central meridian,
 * every station within LEF_SAFE_DY_M of the ship in northing and rho nu >= a^2 (1 - e^2) (its
 * equatorial minimum) >= LEF_SAFE_RHO_NU, that term is below 1.2e12 / 2.34e14 = 0.0052 rad;
 * master and slave chord bearings LEF_SAFE_RAD (0.03 rad, more than twice two such terms)
 * apart then have azimuths apart too. 1: certain (skip), 0: compute the azimuths as before. */
#define LEF_SAFE_X_M 4.0e5
#define LEF_SAFE_DY_M 1.0e6
#define LEF_SAFE_RHO_NU 3.9e13
#define LEF_SAFE_RAD 0.03
static int lef_certain(const chain_t *c, const GeodesicObject *g, double x, double y,
                       double lat0, double lon0)
{
    double bm;
    if (!(isfinite(lat0) && isfinite(lon0) && fabs(x) <= LEF_SAFE_X_M && isfinite(y)
          && c->num >= LEF_SAFE_RHO_NU && g->a >= 6.3e6 && g->f >= 0.0 && g->f <= 0.01
          && g->a * g->a * (1.0 - g->f * (2.0 - g->f)) >= LEF_SAFE_RHO_NU))
        return 0;
    for (int i = 0; i < 4; i++)
        if (!(fabs(c->st[i][0]) <= LEF_SAFE_X_M && fabs(c->st[i][1] - y) <= LEF_SAFE_DY_M))
            return 0;
    bm = atan2(c->st[0][0] - x, c->st[0][1] - y);
    for (int s = 1; s < 4; s++) {
        double d = fabs(atan2(c->st[s][0] - x, c->st[s][1] - y) - bm);
        if (d > Py_MATH_PI)
            d = TWO_PI - d;
        if (!(d >= LEF_SAFE_RAD))
            return 0;
    }
    return 1;
}

/* _lef_certain(sc, geodesic, x, y, lat0, lon0) -> bool: lef_certain, for the tests. */
static PyObject *py_lef_certain(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    double x, y, lat0, lon0;
    if (nargs != 6 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[2], &x) || arg_float(args[3], &y) || arg_float(args[4], &lat0)
        || arg_float(args[5], &lon0))
        Py_RETURN_NOTIMPLEMENTED;
    return PyBool_FromLong(lef_certain(&c, (GeodesicObject *)args[1], x, y, lat0, lon0));
}

/* decca._vcv_core then decca._vcv_m2 (m^2), the same operations. */
static const double MM01 = 12.0, MM02 = 20.0, MM12 = 15.0;     /* 4*3, 4*5, 3*5 */
static const double MM0_2 = 16.0, MM1_2 = 9.0, MM2_2 = 25.0;   /* (4, 3, 5) ** 2 */
static const double MS0_2 = 9.0, MS1_2 = 4.0, MS2_2 = 36.0;    /* (3, 2, 6) ** 2 */
static double SYNC_2[3];                                       /* (0.012, 0.009, 0.015) ** 2 */

static int vcv_m2(double d_master, const double d_slave[3], const double sky[3], double cf,
                  const double k[3], double out[3][3])
{
    const double h = 1e-5;
    double d, s_n2, s_r, s_g, s_p, q, o01, o02, o12, c00, c11, c22, t;
    d = d_master * h;
    if (py_square((2.407 * d * d - 2.273 * d + 4.240) * 1e-3, &s_n2) < 0)
        return -1;
    d = d_slave[0] * h;
    s_r = (2.407 * d * d - 2.273 * d + 4.240) * 1e-3;
    d = d_slave[1] * h;
    s_g = (2.407 * d * d - 2.273 * d + 4.240) * 1e-3;
    d = d_slave[2] * h;
    s_p = (2.843 * d * d - 2.597 * d + 5.000) * 1e-3;
    PYDIV(o01, MM01 * s_n2, cf);
    PYDIV(o02, MM02 * s_n2, cf);
    PYDIV(o12, MM12 * s_n2, cf);
    if (py_square(s_r, &q) < 0)
        return -1;
    PYDIV(t, MM0_2 * (s_n2 + sky[0]) + MS0_2 * q, cf);
    c00 = t + SYNC_2[0];
    if (py_square(s_g, &q) < 0)
        return -1;
    PYDIV(t, MM1_2 * (s_n2 + sky[1]) + MS1_2 * q, cf);
    c11 = t + SYNC_2[1];
    if (py_square(s_p, &q) < 0)
        return -1;
    PYDIV(t, MM2_2 * (s_n2 + sky[2]) + MS2_2 * q, cf);
    c22 = t + SYNC_2[2];
    {
        double m01 = o01 * (k[0] * k[1]), m02 = o02 * (k[0] * k[2]), m12 = o12 * (k[1] * k[2]);
        out[0][0] = c00 * (k[0] * k[0]);
        out[0][1] = m01;
        out[0][2] = m02;
        out[1][0] = m01;
        out[1][1] = c11 * (k[1] * k[1]);
        out[1][2] = m12;
        out[2][0] = m02;
        out[2][1] = m12;
        out[2][2] = c22 * (k[2] * k[2]);
    }
    return 0;
}

/* list[i] = v for an exact list (IndexError beyond its end, as the assignment raises). */
static int set_float(PyObject *list, Py_ssize_t i, double v)
{
    PyObject *f = PyFloat_FromDouble(v);
    if (f == NULL)
        return -1;
    return PyList_SetItem(list, i, f); /* steals f */
}

/* Write out[3][3] into Cl[s0:s0+3, s0:s0+3]: straight into a writable float64 numpy array
 * (its data and strides read from the array, uvn_numpy.h: what its buffer would give), else
 * through the buffer protocol: 1 where Cl is not a writable 2-D float64 buffer holding that
 * block (the caller assigns the returned list). */
static int write_block(PyObject *cl, Py_ssize_t s0, double out[3][3])
{
    np_fields_t *f;
    if (np_layout < 0 && np_ready() < 0)
        PyErr_Clear();
    f = np_direct(cl, 2);
    if (f != NULL && (PyArray_FLAGS(f) & NP_WRITEABLE) && s0 >= 0 && s0 + 3 <= PyArray_DIMS(f)[0]
        && s0 + 3 <= PyArray_DIMS(f)[1]) {
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                *(double *)(PyArray_BYTES(f) + (s0 + i) * PyArray_STRIDES(f)[0] + (s0 + j) * PyArray_STRIDES(f)[1]) =
                    out[i][j];
        return 0;
    }
    Py_buffer v;
    if (PyObject_GetBuffer(cl, &v, PyBUF_RECORDS) < 0) {
        PyErr_Clear();
        return 1;
    }
    if (v.ndim != 2 || v.itemsize != 8 || v.format == NULL
        || !(strcmp(v.format, "d") == 0 || strcmp(v.format, "<d") == 0
             || strcmp(v.format, "=d") == 0)
        || v.strides == NULL || s0 < 0 || s0 + 3 > v.shape[0] || s0 + 3 > v.shape[1]
        || v.suboffsets != NULL) {
        PyBuffer_Release(&v);
        return 1;
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            *(double *)((char *)v.buf + (s0 + i) * v.strides[0] + (s0 + j) * v.strides[1]) =
                out[i][j];
    PyBuffer_Release(&v);
    return 0;
}

/* linearise(sc, geodesic, x, y, lat0, lon0, observed, slot0, A, b, Cl, cf): the body of
 * DeccaObservations._linearise_py after (lat0, lon0), with the model's own decca_vcv_m2.
 * Returns None (Cl written), the 3x3 nested list for Cl[s, s] (Cl not a float64 buffer), or
 * NotImplemented (arguments not of the fast path's types; nothing written). */
static PyObject *py_linearise(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    double x, y, lat0, lon0, cf, az[4], lef[3], k[3], obs[3], out[3][3];
    Py_ssize_t slot0;
    PyObject *observed, *A, *b;
    lanes_t o;
    if (nargs != 12 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[2], &x) || arg_float(args[3], &y) || arg_float(args[4], &lat0)
        || arg_float(args[5], &lon0) || arg_float(args[11], &cf))
        Py_RETURN_NOTIMPLEMENTED;
    observed = args[6];
    if (!PyList_CheckExact(observed) || PyList_GET_SIZE(observed) != 3)
        Py_RETURN_NOTIMPLEMENTED;
    for (int j = 0; j < 3; j++) {
        PyObject *ob = PyList_GET_ITEM(observed, j);
        if (!PyFloat_Check(ob))
            Py_RETURN_NOTIMPLEMENTED;
        obs[j] = PyFloat_AS_DOUBLE(ob);
    }
    if (!PyLong_CheckExact(args[7]))
        Py_RETURN_NOTIMPLEMENTED;
    slot0 = PyLong_AsSsize_t(args[7]);
    if (slot0 < 0) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    A = args[8];
    b = args[9];
    if (!PyList_CheckExact(A) || !PyList_CheckExact(b))
        Py_RETURN_NOTIMPLEMENTED;
    if (lane_model(&c, x, y, lat0, &o) < 0)
        return NULL;
    azimuths((GeodesicObject *)args[1], &c, lat0, lon0, az);
    if (PyErr_Occurred() || lef_of(az, lef) < 0)
        return NULL;
    for (int j = 0; j < 3; j++)
        k[j] = c.lam[j] * lef[j] / 2.0;
    for (int j = 0; j < 3; j++) {
        double ob = obs[j];
        if (ob == ob) {
            Py_ssize_t i = slot0 + j;
            if (set_float(A, 2 * i, o.row_x[j] * k[j]) < 0
                || set_float(A, 2 * i + 1, o.row_y[j] * k[j]) < 0
                || set_float(b, i, (ob - o.n_calc[j]) * k[j]) < 0)
                return NULL;
        }
    }
    if (vcv_m2(o.dist[0], o.dist + 1, c.sky, cf, k, out) < 0)
        return NULL;
    if (write_block(args[10], slot0, out) == 0)
        Py_RETURN_NONE;
    return Py_BuildValue("[[ddd][ddd][ddd]]", out[0][0], out[0][1], out[0][2], out[1][0],
                         out[1][1], out[1][2], out[2][0], out[2][1], out[2][2]);
}

/* gps_rows(A, b, Cl, slot0, north, east, px, py, var): engine.systems.gps's coordinate rows
 * (_GpsObservations.linearise) with north = y + corr_north, east = x + corr_east (m): A's
 * rows (0, 1) and (1, 0) at slots slot0 and slot0 + 1, b = north - py, east - px, and var on
 * Cl's diagonal there. None, or NotImplemented (nothing written) where Cl is not a writable
 * float64 numpy array holding those slots or an argument is of another kind. */
static PyObject *py_gps_rows(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    PyObject *A, *b, *v[6];
    Py_ssize_t s0, n;
    double north, east, px, py, var;
    np_fields_t *f;
    if (nargs != 9 || !PyList_CheckExact(args[0]) || !PyList_CheckExact(args[1])
        || !PyLong_CheckExact(args[3]) || arg_float(args[4], &north)
        || arg_float(args[5], &east) || arg_float(args[6], &px) || arg_float(args[7], &py)
        || arg_float(args[8], &var))
        Py_RETURN_NOTIMPLEMENTED;
    A = args[0];
    b = args[1];
    s0 = PyLong_AsSsize_t(args[3]);
    if (s0 < 0) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    if (np_layout < 0 && np_ready() < 0)
        PyErr_Clear();
    f = np_direct(args[2], 2);
    n = PyList_GET_SIZE(b);
    if (f == NULL || !(PyArray_FLAGS(f) & NP_WRITEABLE) || s0 + 2 > PyArray_DIMS(f)[0]
        || s0 + 2 > PyArray_DIMS(f)[1] || 2 * (s0 + 2) > PyList_GET_SIZE(A) || s0 + 2 > n)
        Py_RETURN_NOTIMPLEMENTED;
    v[0] = PyFloat_FromDouble(0.0);
    v[1] = PyFloat_FromDouble(1.0);
    v[2] = PyFloat_FromDouble(1.0);
    v[3] = PyFloat_FromDouble(0.0);
    v[4] = PyFloat_FromDouble(north - py);
    v[5] = PyFloat_FromDouble(east - px);
    for (int i = 0; i < 6; i++)
        if (v[i] == NULL) {
            for (int j = 0; j < 6; j++)
                Py_XDECREF(v[j]);
            return NULL;
        }
    for (int i = 0; i < 4; i++)
        Py_XSETREF(PyList_GET_ITEM(A, 2 * s0 + i), v[i]);
    Py_XSETREF(PyList_GET_ITEM(b, s0), v[4]);
    Py_XSETREF(PyList_GET_ITEM(b, s0 + 1), v[5]);
    *(double *)(PyArray_BYTES(f) + s0 * PyArray_STRIDES(f)[0] + s0 * PyArray_STRIDES(f)[1]) = var;
    *(double *)(PyArray_BYTES(f) + (s0 + 1) * PyArray_STRIDES(f)[0] + (s0 + 1) * PyArray_STRIDES(f)[1]) = var;
    Py_RETURN_NONE;
}

static PyObject *s_grid, *s_x, *s_y, *s_latlon;

/* linearise_at(sc, geodesic, inverse, packed, grid, p, observed, slot0, A, b, Cl, cf):
 * DeccaObservations.linearise for a Point ``p`` on the chain's ``grid``: its (lat, lon) is
 * p._latlon, or, not yet set, the tmgrid kernel's inverse(packed, p.x, p.y) (what p.latlon
 * calls through TMGrid.inverse, with its memo), then set as p.latlon sets it; then linearise.
 * NotImplemented (nothing written or set) for another grid, an inverse the kernel declines,
 * or arguments linearise does not take. */
static PyObject *py_linearise_at(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    PyObject *p, *g, *x, *y, *ll, *a[12], *r;
    if (nargs != 12)
        Py_RETURN_NOTIMPLEMENTED;
    p = args[5];
    g = PyObject_GetAttr(p, s_grid);
    if (g == NULL)
        goto decline;
    Py_DECREF(g); /* identity only */
    if (g != args[4])
        Py_RETURN_NOTIMPLEMENTED;
    x = PyObject_GetAttr(p, s_x);
    y = x == NULL ? NULL : PyObject_GetAttr(p, s_y);
    ll = y == NULL ? NULL : PyObject_GetAttr(p, s_latlon);
    if (ll == NULL) {
        Py_XDECREF(x);
        Py_XDECREF(y);
        goto decline;
    }
    if (!PyFloat_CheckExact(x) || !PyFloat_CheckExact(y)) {
        r = Py_NewRef(Py_NotImplemented);
        goto done;
    }
    if (ll == Py_None) {
        PyObject *ia[3] = {args[3], x, y};
        Py_DECREF(ll);
        ll = PyObject_Vectorcall(args[2], ia, 3, NULL);
        if (ll == NULL) {
            Py_DECREF(x);
            Py_DECREF(y);
            goto decline;
        }
        if (ll == Py_None) { /* the kernel declines: TMGrid.inverse runs its Python */
            r = Py_NewRef(Py_NotImplemented);
            goto done;
        }
        if (PyObject_SetAttr(p, s_latlon, ll) < 0) {
            r = NULL;
            goto done;
        }
    }
    if (!PyTuple_CheckExact(ll) || PyTuple_GET_SIZE(ll) != 2) {
        r = Py_NewRef(Py_NotImplemented);
        goto done;
    }
    a[0] = args[0];
    a[1] = args[1];
    a[2] = x;
    a[3] = y;
    a[4] = PyTuple_GET_ITEM(ll, 0);
    a[5] = PyTuple_GET_ITEM(ll, 1);
    for (int i = 6; i < 12; i++)
        a[i] = args[i];
    r = py_linearise(m, a, 12);
done:
    Py_DECREF(x);
    Py_DECREF(y);
    Py_DECREF(ll);
    return r;
decline:
    PyErr_Clear();
    Py_RETURN_NOTIMPLEMENTED;
}

/* vcv_m2(d_master, d_slave, baseline_sky, cf, k) -> _vcv_m2(_vcv_core(...), k), for the tests. */
static PyObject *py_vcv_m2(PyObject *m, PyObject *args)
{
    double dm, ds[3], sky[3], cf, k[3], out[3][3];
    if (!PyArg_ParseTuple(args, "d(ddd)(ddd)d(ddd):vcv_m2", &dm, ds, ds + 1, ds + 2, sky,
                          sky + 1, sky + 2, &cf, k, k + 1, k + 2))
        return NULL;
    if (vcv_m2(dm, ds, sky, cf, k, out) < 0)
        return NULL;
    return Py_BuildValue("[[ddd][ddd][ddd]]", out[0][0], out[0][1], out[0][2], out[1][0],
                         out[1][1], out[1][2], out[2][0], out[2][1], out[2][2]);
}

/* ------------------------------------------------------------------ lane_sigma */
#define p_dgemv uvn_dgemv
#define p_ddot uvn_ddot

/* A C-contiguous native float64 buffer of ndim dims with these shape entries, else 1. */
static int f64_buffer(PyObject *o, Py_buffer *v, int ndim, const Py_ssize_t *shape)
{
    if (!PyObject_CheckBuffer(o) || PyObject_GetBuffer(o, v, PyBUF_RECORDS_RO) < 0) {
        PyErr_Clear();
        return 1;
    }
    if (v->ndim != ndim || v->itemsize != 8 || v->format == NULL
        || !(strcmp(v->format, "d") == 0 || strcmp(v->format, "<d") == 0)
        || v->suboffsets != NULL || !PyBuffer_IsContiguous(v, 'C'))
        goto no;
    for (int i = 0; i < ndim; i++)
        if (v->shape[i] != shape[i])
            goto no;
    return 0;
no:
    PyBuffer_Release(v);
    return 1;
}

/* lane_sigma(row, cov) -> decca._lane_sigma_py(row, cov) = sqrt(max(float(row @ cov @ row),
 * 0.0)) for a contiguous float64 row (2,) and a C-contiguous float64 cov (2, 2), through
 * numpy's matmul routines: y = dgemv(RowMajor, Trans, 2, 2, 1.0, cov, 2, row, 1, 0.0, y, 1),
 * then DOUBLE_dot's sum = 0.0; sum += ddot(2, y, 1, row, 1). NotImplemented otherwise. */
static PyObject *py_lane_sigma(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    static const Py_ssize_t s1[1] = {2}, s2[2] = {2, 2};
    Py_buffer vr, vc;
    double y[2], sum, q;
    if (nargs != 2)
        Py_RETURN_NOTIMPLEMENTED;
    if (f64_buffer(args[0], &vr, 1, s1))
        Py_RETURN_NOTIMPLEMENTED;
    if (f64_buffer(args[1], &vc, 2, s2)) {
        PyBuffer_Release(&vr);
        Py_RETURN_NOTIMPLEMENTED;
    }
    y[0] = y[1] = 0.0;
    p_dgemv(UvnRowMajor, UvnTrans, 2, 2, 1.0, (const double *)vc.buf, 2,
            (const double *)vr.buf, 1, 0.0, y, 1);
    sum = 0.;
    sum += p_ddot(2, y, 1, (const double *)vr.buf, 1);
    PyBuffer_Release(&vr);
    PyBuffer_Release(&vc);
    q = (0.0 > sum) ? 0.0 : sum; /* max(q, 0.0) */
    return PyFloat_FromDouble(sqrt(q));
}

/* ------------------------------------------------------------------ decca_totals, tracked */
static PyObject *s_total_seconds, *s_totals, *s_track, *s_notes, *s_slips;

/* _LaneAt.lanes_at(gps)'s numbers at grid (gx, gy): the grid inverted by the tmgrid kernel's
 * inverse (inv(packed, gx, gy), its memo as TMGrid.inverse uses it), the lane model and the
 * LEF's check. 1: lanes in *o (N_calc finite), 0: None (N_calc not finite), -1: anything else
 * (no inverse from the kernel, an error: nothing set, the caller declines). */
static int gps_lanes(const chain_t *c, const GeodesicObject *g, PyObject *inv, PyObject *packed,
                     double gx, double gy, lanes_t *o)
{
    PyObject *a[3], *r;
    double lat0, lon0, az[4], lef[3];
    a[0] = packed;
    a[1] = PyFloat_FromDouble(gx);
    a[2] = PyFloat_FromDouble(gy);
    if (a[1] == NULL || a[2] == NULL) {
        Py_XDECREF(a[1]);
        Py_XDECREF(a[2]);
        return -1;
    }
    r = PyObject_Vectorcall(inv, a, 3, NULL);
    Py_DECREF(a[1]);
    Py_DECREF(a[2]);
    if (r == NULL)
        return -1;
    if (!PyTuple_CheckExact(r) || PyTuple_GET_SIZE(r) != 2 || item_float(r, 0, &lat0)
        || item_float(r, 1, &lon0)) {
        Py_DECREF(r);
        return -1;
    }
    Py_DECREF(r);
    if (lane_model(c, gx, gy, lat0, o) < 0)
        return -1;
    if (!lef_certain(c, g, gx, gy, lat0, lon0)) {
        azimuths(g, c, lat0, lon0, az);
        if (PyErr_Occurred() || lef_of(az, lef) < 0)
            return -1;
    }
    for (int j = 0; j < 3; j++)
        if (!isfinite(o->n_calc[j]))
            return 0;
    return 1;
}

/* lanes(sc, geodesic, inverse, packed, x, y) -> tuple of 13 floats | None | NotImplemented:
 * _LaneAt._lanes' numbers at grid (x, y) by gps_lanes (the grid inverted by the tmgrid
 * kernel's inverse, the lane model, the LEF's check): distances master, red, green, purple (m),
 * N_calc red, green, purple (lanes), then dN/dx, dN/dy of red, green, purple (lanes/m). None
 * where N_calc is not finite; NotImplemented for arguments of another kind and wherever
 * gps_lanes cannot answer (an error on the way, a LEF that raises): the caller declines. */
static PyObject *py_lanes(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    double x, y;
    lanes_t o;
    int r;
    if (nargs != 6 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[4], &x) || arg_float(args[5], &y))
        Py_RETURN_NOTIMPLEMENTED;
    r = gps_lanes(&c, (const GeodesicObject *)args[1], args[2], args[3], x, y, &o);
    if (r < 0) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    if (r == 0)
        Py_RETURN_NONE;
    return Py_BuildValue("(ddddddddddddd)", o.dist[0], o.dist[1], o.dist[2], o.dist[3],
                         o.n_calc[0], o.n_calc[1], o.n_calc[2], o.row_x[0], o.row_y[0],
                         o.row_x[1], o.row_y[1], o.row_x[2], o.row_y[2]);
}

/* (time - t_prev).total_seconds() into *out: 0, -1 (an error: the caller declines). */
static int seconds_between(PyObject *time, PyObject *t_prev, double *out)
{
    PyObject *dt = PyNumber_Subtract(time, t_prev), *s;
    if (dt == NULL)
        return -1;
    s = PyObject_CallMethodNoArgs(dt, s_total_seconds);
    Py_DECREF(dt);
    if (s == NULL)
        return -1;
    if (!PyFloat_CheckExact(s)) {
        Py_DECREF(s);
        return -1;
    }
    *out = PyFloat_AS_DOUBLE(s);
    Py_DECREF(s);
    return 0;
}

/* track_lane(p0, frac) (= identify_lane) into *out: 0, 1 where math.floor would raise. */
static int track_of(double p0, double frac, double *out)
{
    double d;
    if (!isfinite(p0))
        return 1;
    d = frac - (p0 - floor(p0)); /* math.floor's int converts back to the same double */
    if (!isfinite(d + 0.5))
        return 1;
    *out = p0 + (d - floor(d + 0.5));
    return 0;
}

/* tracked(sc, geodesic, inverse, packed, track, fractions, time, gps_x, gps_y, gps_var, gap_s,
 *         sigma_max, cls) -> cls instance (LaneTotals) or NotImplemented.
 * decca.decca_totals where every pattern read is tracked (its last total within gap_s seconds)
 * and GPS (the source at grid (gps_x, gps_y) with the VCV _EYE2 * gps_var; gps_x None: no GPS)
 * finds no lane slip: the totals, the new track, no notes, no slips. NotImplemented for
 * everything else (a first reading, a gap, a slip, arguments or values of another kind, an
 * error on the way): then the Python runs, and gives the same or its notes and errors. */
static PyObject *py_tracked(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    chain_t c;
    const GeodesicObject *g;
    PyObject *track, *fractions, *time, *last_time = NULL, *obj, *tot = NULL, *trk = NULL;
    double gx = 0.0, gy = 0.0, gvar = 0.0, gap, smax, last_s = 0.0, totals[3];
    double cov[4] __attribute__((aligned(16))) = {0.0, 0.0, 0.0, 0.0};
    int has_gps, gps_state = -2, has[3];
    lanes_t gl;
    PyTypeObject *cls;
    if (nargs != 13 || read_chain(args[0], &c) || check_geodesic(args[1])
        || arg_float(args[10], &gap) || arg_float(args[11], &smax) || !PyType_Check(args[12]))
        Py_RETURN_NOTIMPLEMENTED;
    g = (const GeodesicObject *)args[1];
    track = args[4];
    fractions = args[5];
    time = args[6];
    cls = (PyTypeObject *)args[12];
    if (!PyTuple_CheckExact(track) || PyTuple_GET_SIZE(track) != 3
        || !PyTuple_CheckExact(fractions) || PyTuple_GET_SIZE(fractions) != 3)
        Py_RETURN_NOTIMPLEMENTED;
    has_gps = args[7] != Py_None;
    if (has_gps) {
        if (arg_float(args[7], &gx) || arg_float(args[8], &gy) || arg_float(args[9], &gvar))
            Py_RETURN_NOTIMPLEMENTED;
        /* _EYE2 * var, numpy's elementwise products */
        cov[0] = 1.0 * gvar;
        cov[1] = 0.0 * gvar;
        cov[2] = 0.0 * gvar;
        cov[3] = 1.0 * gvar;
    }
    for (int i = 0; i < 3; i++) {
        PyObject *fo = PyTuple_GET_ITEM(fractions, i), *prev, *t_prev;
        double frac, p0, total;
        has[i] = 0;
        if (fo == Py_None)
            continue;
        prev = PyTuple_GET_ITEM(track, i);
        if (!PyFloat_CheckExact(fo) || !PyTuple_CheckExact(prev) || PyTuple_GET_SIZE(prev) != 2
            || !PyFloat_CheckExact(PyTuple_GET_ITEM(prev, 0)))
            Py_RETURN_NOTIMPLEMENTED; /* a first reading (None) or another kind */
        frac = PyFloat_AS_DOUBLE(fo);
        p0 = PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(prev, 0));
        t_prev = PyTuple_GET_ITEM(prev, 1);
        if (t_prev != last_time) {
            if (seconds_between(time, t_prev, &last_s) < 0)
                goto decline;
            last_time = t_prev;
        }
        if (!(last_s <= gap) || track_of(p0, frac, &total))
            Py_RETURN_NOTIMPLEMENTED; /* a gap: the lane identified again (Python) */
        if (has_gps) {
            if (gps_state == -2)
                gps_state = gps_lanes(&c, g, args[2], args[3], gx, gy, &gl);
            if (gps_state < 0)
                goto decline;
            if (gps_state == 1) {
                /* decca._gps_lane_check: the GPS lane's sigma, lane and slip */
                double row[2] __attribute__((aligned(16))), y[2], sum, sigma, expected, x, rd;
                row[0] = gl.row_x[i];
                row[1] = gl.row_y[i];
                y[0] = y[1] = 0.0;
                p_dgemv(UvnRowMajor, UvnTrans, 2, 2, 1.0, cov, 2, row, 1, 0.0, y, 1);
                sum = 0.;
                sum += p_ddot(2, y, 1, row, 1);
                sigma = sqrt((0.0 > sum) ? 0.0 : sum);
                if (sigma <= smax) {
                    if (track_of(gl.n_calc[i], frac, &expected))
                        Py_RETURN_NOTIMPLEMENTED;
                    x = total - expected;
                    if (!isfinite(x))
                        Py_RETURN_NOTIMPLEMENTED;
                    rd = round(x); /* float.__round__: half to even */
                    if (fabs(x - rd) == 0.5)
                        rd = 2.0 * round(x / 2.0);
                    if (rd != 0.0)
                        Py_RETURN_NOTIMPLEMENTED; /* a lane slip: the Python writes its note */
                }
            }
        }
        totals[i] = total;
        has[i] = 1;
    }
    tot = PyTuple_New(3);
    trk = PyTuple_New(3);
    if (tot == NULL || trk == NULL)
        goto fail;
    for (int i = 0; i < 3; i++) {
        PyObject *t, *f;
        if (!has[i]) {
            Py_INCREF(Py_None);
            PyTuple_SET_ITEM(tot, i, Py_None);
            t = PyTuple_GET_ITEM(track, i);
            Py_INCREF(t);
            PyTuple_SET_ITEM(trk, i, t);
            continue;
        }
        f = PyFloat_FromDouble(totals[i]);
        if (f == NULL)
            goto fail;
        PyTuple_SET_ITEM(tot, i, f);
        Py_INCREF(f);
        t = PyTuple_Pack(2, f, time);
        Py_DECREF(f);
        if (t == NULL)
            goto fail;
        PyTuple_SET_ITEM(trk, i, t);
    }
    obj = cls->tp_alloc(cls, 0);
    if (obj == NULL)
        goto fail;
    {
        PyObject *notes = PyTuple_New(0), *zero = PyLong_FromLong(0);
        int bad = notes == NULL || zero == NULL || PyObject_GenericSetAttr(obj, s_totals, tot) < 0
                  || PyObject_GenericSetAttr(obj, s_track, trk) < 0
                  || PyObject_GenericSetAttr(obj, s_notes, notes) < 0
                  || PyObject_GenericSetAttr(obj, s_slips, zero) < 0;
        Py_XDECREF(notes);
        Py_XDECREF(zero);
        Py_DECREF(tot);
        Py_DECREF(trk);
        if (bad) {
            Py_DECREF(obj);
            return NULL;
        }
    }
    return obj;
fail:
    Py_XDECREF(tot);
    Py_XDECREF(trk);
    return NULL;
decline:
    PyErr_Clear();
    Py_RETURN_NOTIMPLEMENTED;
}

static PyObject *py_sync_sq(PyObject *m, PyObject *noargs)
{
    return Py_BuildValue("(ddd)", SYNC_2[0], SYNC_2[1], SYNC_2[2]);
}

/* page(n_calc, lop_az, raw, corrections, names, system, make) -> list | NotImplemented:
 * DeccaObservations._readings_py's list, [make(i, system, names[i], raw[i], corrections[i],
 * n_calc[i], math.degrees(lop_az[i])) for i, raw in enumerate(raw) if raw is not None], for
 * float64 arrays of 3 (uvn_numpy.h) and tuples of 3; math.degrees is CPython's x * (180/pi)
 * (mathmodule.c's radToDeg, the same constant; tests/native/test_decca_glue.py compares). */
static const double RAD_TO_DEG = 180.0 / Py_MATH_PI;

static PyObject *py_page(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    np_fields_t *fn, *fa;
    PyObject *out, *raw, *corr, *names;
    if (nargs != 7 || !PyTuple_CheckExact(args[2]) || !PyTuple_CheckExact(args[3])
        || !PyTuple_CheckExact(args[4]) || PyTuple_GET_SIZE(args[2]) != 3
        || PyTuple_GET_SIZE(args[3]) != 3 || PyTuple_GET_SIZE(args[4]) != 3)
        Py_RETURN_NOTIMPLEMENTED;
    if (np_layout < 0 && np_ready() < 0) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    fn = np_direct(args[0], 1);
    fa = np_direct(args[1], 1);
    if (fn == NULL || fa == NULL || PyArray_DIMS(fn)[0] != 3 || PyArray_DIMS(fa)[0] != 3)
        Py_RETURN_NOTIMPLEMENTED;
    raw = args[2];
    corr = args[3];
    names = args[4];
    out = PyList_New(0);
    if (out == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < 3; i++) {
        PyObject *r = PyTuple_GET_ITEM(raw, i), *a[7], *row;
        double nc, az;
        int rc;
        if (r == Py_None)
            continue;
        nc = *(double *)(PyArray_BYTES(fn) + i * PyArray_STRIDES(fn)[0]);
        az = *(double *)(PyArray_BYTES(fa) + i * PyArray_STRIDES(fa)[0]);
        a[0] = PyLong_FromSsize_t(i);
        a[1] = args[5];
        a[2] = PyTuple_GET_ITEM(names, i);
        a[3] = r;
        a[4] = PyTuple_GET_ITEM(corr, i);
        a[5] = PyFloat_FromDouble(nc);
        a[6] = PyFloat_FromDouble(az * RAD_TO_DEG);
        row = (a[0] == NULL || a[5] == NULL || a[6] == NULL) ? NULL
              : PyObject_Vectorcall(args[6], a, 7, NULL);
        Py_XDECREF(a[0]);
        Py_XDECREF(a[5]);
        Py_XDECREF(a[6]);
        rc = row == NULL ? -1 : PyList_Append(out, row);
        Py_XDECREF(row);
        if (rc < 0) {
            Py_DECREF(out);
            return NULL;
        }
    }
    return out;
}

/* nearest(d_master, d_slave, used) -> float | NotImplemented: DeccaObservations.nearest_station_m
 * after its geometry: near = inf; near = min(near, d_master, d_slave[i]) for each i of 3 whose
 * used[i] is true (min's own order: the first smallest by `<`), d_slave a float64 array of 3,
 * d_master a float, used a list or tuple of at least 3. */
static PyObject *py_nearest(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    np_fields_t *fs;
    PyObject *used;
    double dm, near = Py_HUGE_VAL;
    if (nargs != 3 || !PyFloat_CheckExact(args[0])
        || !(PyList_CheckExact(args[2]) || PyTuple_CheckExact(args[2])))
        Py_RETURN_NOTIMPLEMENTED;
    if (np_layout < 0 && np_ready() < 0) {
        PyErr_Clear();
        Py_RETURN_NOTIMPLEMENTED;
    }
    fs = np_direct(args[1], 1);
    used = args[2];
    if (fs == NULL || PyArray_DIMS(fs)[0] != 3 || PySequence_Fast_GET_SIZE(used) < 3)
        Py_RETURN_NOTIMPLEMENTED;
    dm = PyFloat_AS_DOUBLE(args[0]);
    for (Py_ssize_t i = 0; i < 3; i++) {
        int t = PyObject_IsTrue(PySequence_Fast_GET_ITEM(used, i));
        if (t < 0)
            return NULL;
        if (t) {
            double ds = *(double *)(PyArray_BYTES(fs) + i * PyArray_STRIDES(fs)[0]), cur = near;
            if (dm < cur)
                cur = dm;
            if (ds < cur)
                cur = ds;
            near = cur;
        }
    }
    return PyFloat_FromDouble(near);
}

/* observed(totals, fractions, corrections, selected, nan) -> (observed, raw, available) |
 * NotImplemented: DeccaSystem.observations' loop for tracked totals. Each a list of 3 that
 * starts [nan] * 3, [None] * 3, [False] * 3; for each pattern i whose total and fraction are
 * not None: raw[i] = float(totals[i]), observed[i] = raw[i] + corrections[i] (IEEE add) and
 * available[i] = selected[i]. Tuples of 3, totals and corrections exact floats (else
 * NotImplemented: the Python's float() and + run); nan: the caller's math.nan. */
static PyObject *py_observed(PyObject *m, PyObject *const *args, Py_ssize_t nargs)
{
    PyObject *obs, *raw, *av;
    if (nargs != 5)
        Py_RETURN_NOTIMPLEMENTED;
    for (int k = 0; k < 4; k++)
        if (!PyTuple_CheckExact(args[k]) || PyTuple_GET_SIZE(args[k]) != 3)
            Py_RETURN_NOTIMPLEMENTED;
    for (Py_ssize_t i = 0; i < 3; i++) {
        PyObject *t = PyTuple_GET_ITEM(args[0], i);
        if (t != Py_None && PyTuple_GET_ITEM(args[1], i) != Py_None
            && (!PyFloat_CheckExact(t) || !PyFloat_CheckExact(PyTuple_GET_ITEM(args[2], i))))
            Py_RETURN_NOTIMPLEMENTED;
    }
    obs = PyList_New(3);
    raw = PyList_New(3);
    av = PyList_New(3);
    if (obs == NULL || raw == NULL || av == NULL)
        goto fail;
    for (Py_ssize_t i = 0; i < 3; i++) {
        PyObject *t = PyTuple_GET_ITEM(args[0], i);
        if (t != Py_None && PyTuple_GET_ITEM(args[1], i) != Py_None) {
            PyObject *o = PyFloat_FromDouble(PyFloat_AS_DOUBLE(t)
                                             + PyFloat_AS_DOUBLE(PyTuple_GET_ITEM(args[2], i)));
            if (o == NULL)
                goto fail; /* the lists' unset items are NULL: freed alike */
            PyList_SET_ITEM(obs, i, o);
            PyList_SET_ITEM(raw, i, Py_NewRef(t));
            PyList_SET_ITEM(av, i, Py_NewRef(PyTuple_GET_ITEM(args[3], i)));
        } else {
            PyList_SET_ITEM(obs, i, Py_NewRef(args[4]));
            PyList_SET_ITEM(raw, i, Py_NewRef(Py_None));
            PyList_SET_ITEM(av, i, Py_NewRef(Py_False));
        }
    }
    return Py_BuildValue("(NNN)", obs, raw, av);
fail:
    Py_XDECREF(obs);
    Py_XDECREF(raw);
    Py_XDECREF(av);
    return NULL;
}

static PyMethodDef methods[] = {
    UVN_PROBE_METHOD,
    {"geometry_new", (PyCFunction)(void (*)(void))py_geometry_new, METH_FASTCALL,
     "decca_geometry's DeccaGeometry in one call (its arrays made here)."},
    {"geometry", (PyCFunction)(void (*)(void))py_geometry, METH_FASTCALL,
     "decca_geometry's numbers: (d_master, az_master, block of 24)."},
    {"_lef_certain", (PyCFunction)(void (*)(void))py_lef_certain, METH_FASTCALL,
     "Whether lanes() may skip the LEF's geodesics (it cannot raise there; tests)."},
    {"gps_rows", (PyCFunction)(void (*)(void))py_gps_rows, METH_FASTCALL,
     "engine.systems.gps's two coordinate rows written in one call."},
    {"linearise_at", (PyCFunction)(void (*)(void))py_linearise_at, METH_FASTCALL,
     "DeccaObservations.linearise at a Point on the chain's grid, its latlon made here."},
    {"linearise", (PyCFunction)(void (*)(void))py_linearise, METH_FASTCALL,
     "DeccaObservations.linearise's rows and VCV block."},
    {"vcv_m2", (PyCFunction)py_vcv_m2, METH_VARARGS, "_vcv_m2(_vcv_core(...), k)."},
    {"lane_sigma", (PyCFunction)(void (*)(void))py_lane_sigma, METH_FASTCALL,
     "decca.lane_sigma through numpy's dgemv and ddot."},
    {"observed", (PyCFunction)(void (*)(void))py_observed, METH_FASTCALL,
     "DeccaSystem.observations' lists for tracked totals."},
    {"page", (PyCFunction)(void (*)(void))py_page, METH_FASTCALL,
     "DeccaObservations.readings' LopReading list after its geometry."},
    {"nearest", (PyCFunction)(void (*)(void))py_nearest, METH_FASTCALL,
     "DeccaObservations.nearest_station_m after its geometry (m)."},
    {"lanes", (PyCFunction)(void (*)(void))py_lanes, METH_FASTCALL,
     "_LaneAt._lanes' distances, N_calc and gradients at a grid point (13 floats)."},
    {"tracked", (PyCFunction)(void (*)(void))py_tracked, METH_FASTCALL,
     "decca_totals where every pattern is tracked and GPS finds no slip: LaneTotals."},
    {"_sync_sq", (PyCFunction)py_sync_sq, METH_NOARGS, "SYNC_SIGMA_LANES ** 2 (tests)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "engine.native.decca",
    "Decca lanes and the geodesic inverse, compiled (the Python's results to the tolerance "
    "contract).", -1,
    methods,
};

PyMODINIT_FUNC PyInit_decca(void)
{
    PyObject *m, *math;
    static const double sync[3] = {0.012, 0.009, 0.015};
    for (int i = 0; i < 3; i++)
        if (py_square(sync[i], &SYNC_2[i]) < 0)
            return NULL;
    math = PyImport_ImportModule("math");
    if (math == NULL)
        return NULL;
    math_hypot = PyObject_GetAttrString(math, "hypot");
    math_atan2 = PyObject_GetAttrString(math, "atan2");
    Py_DECREF(math);
    if (math_hypot == NULL || math_atan2 == NULL)
        return NULL;
    s_total_seconds = PyUnicode_InternFromString("total_seconds");
    s_totals = PyUnicode_InternFromString("totals");
    s_track = PyUnicode_InternFromString("track");
    s_notes = PyUnicode_InternFromString("notes");
    s_slips = PyUnicode_InternFromString("slips");
    s_grid = PyUnicode_InternFromString("grid");
    s_x = PyUnicode_InternFromString("x");
    s_y = PyUnicode_InternFromString("y");
    s_latlon = PyUnicode_InternFromString("_latlon");
    if (s_total_seconds == NULL || s_totals == NULL || s_track == NULL || s_notes == NULL
        || s_slips == NULL || s_grid == NULL || s_x == NULL || s_y == NULL || s_latlon == NULL)
        return NULL;
    if (PyType_Ready(&GeodesicType) < 0)
        return NULL;
    m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    Py_INCREF(&GeodesicType);
    if (PyModule_AddObject(m, "Geodesic", (PyObject *)&GeodesicType) < 0
        || PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
