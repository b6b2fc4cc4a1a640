/* Compiled twin of the scalar Transverse Mercator grid (engine/geodesy/tmgrid.py, TMGrid).
 *
 * forward, forward_full and inverse do the very IEEE operations of TMGrid._forward_py,
 * _forward_full_py and _inverse_py, in the same order (Karney 2011, J. Geodesy 85:475-485,
 * eqs. 7-12, 19-21, 25-28, 35-36; Clenshaw sums on complex arguments):
 *   - Python's complex + - * are written out here (c_sum, c_diff, c_prod: a float operand is
 *     the complex (f, 0.0)); abs() is libm's hypot of the parts;
 *   - cmath.sin, cmath.cos, cmath.phase and math.hypot are called through the C API (cached
 *     function objects): CPython's own code, not libm's;
 *   - math.sin/cos/sinh/atanh/asinh/atan/atan2 are glibc's, as CPython's math module calls
 *     them (m_atan2's own special cases are those of C99 Annex F, and only concern infinite or
 *     zero arguments), through volatile pointers so that gcc neither folds nor merges them
 *     (sin and cos of one argument into sincos); math.remainder is CPython's m_remainder, but
 *     the IEEE remainder is exact (a zero takes the sign of x in both), so glibc's remainder
 *     gives the same bits for the finite arguments it gets here; math.radians/degrees are one
 *     product with the constants math.radians(1.0)/math.degrees(1.0), packed from Python.
 * Built with -ffp-contract=off (no FMA) and without -ffast-math (no reassociation).
 *
 * Only public C API is used; results agree with the Python to rounding (the engine's tolerance
 * contract, docs/PERFORMANCE.md), not necessarily bit for bit.
 *
 * The grid's state travels as one bytearray (pack(), held on the TMGrid instance): its
 * constants, then a memo of the last MEMO inverses (the pure Python's dict memo of
 * TMGrid.inverse, here a ring; only for float arguments that are nonzero and finite, where ==
 * is identity of the bits, so a remembered result is the computed one).
 * Whenever Python would raise or take an exceptional path (an argument that is not a float or
 * an int, a non-finite argument, a math domain or range error, a division by zero, a failing
 * C-API call) a function returns None and the caller runs the pure Python, which then gives the
 * result or the exception itself: the kernel never decides an exceptional case on its own.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <errno.h>
#include <math.h>
#include <string.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST ""
#endif

#define NCOEF 6 /* Kruger series to order n^6: alpha_1..6, beta_1..6 */

/* The constants of one grid (pack() builds them; the layout is private to this file). */
typedef struct {
    double cm;      /* central meridian, degrees (float(cm_deg)) */
    double e;       /* eccentricity */
    double e2m;     /* 1 - e^2 */
    double big_a;   /* rectifying radius A, m */
    double a_ratio; /* A / a_m */
    double e_sq;    /* e**2 (Python pow) */
    double k_pole;  /* e2m**0.5 * exp(e * atanh(e)), the conformal-sphere scale at a pole */
    double deg2rad; /* math.radians(1.0) */
    double rad2deg; /* math.degrees(1.0) */
    double alpha[NCOEF];
    double beta[NCOEF];
} tm_consts;

#define MEMO 8 /* as _INVERSE_MEMO in tmgrid.py */

/* The whole packed state: constants, then the ring of remembered inverses. */
typedef struct {
    tm_consts k;
    double memo[MEMO][4]; /* x, y, lat, lon */
    int n_memo;           /* entries in use */
    int next_memo;        /* slot written next (the oldest once full) */
} tm_state;

/* libm, not foldable or mergeable by the compiler. */
static double (*volatile v_sin)(double) = sin;
static double (*volatile v_cos)(double) = cos;
static double (*volatile v_sinh)(double) = sinh;
static double (*volatile v_atanh)(double) = atanh;
static double (*volatile v_asinh)(double) = asinh;
static double (*volatile v_atan)(double) = atan;
static double (*volatile v_atan2)(double, double) = atan2;
static double (*volatile v_remainder)(double, double) = remainder;

/* Cached Python callables and the float 1.0. */
static PyObject *g_hypot, *g_csin, *g_ccos, *g_cphase, *g_one;

/* A math.* function of one argument would raise (CPython math_1: a NaN from a non-NaN, an
 * infinity from a finite argument). */
#define M1_BAD(r, x) ((isnan(r) && !isnan(x)) || (isinf(r) && isfinite(x)))

/* Fail: the caller falls back to the pure Python. */
#define BAIL() goto bail

/* math.hypot(x, y) through the C API; x_obj may be g_one for x == 1.0. 0 on success. */
static int
api_hypot(PyObject *x_obj, double x, double y, double *out)
{
    PyObject *args[2];
    PyObject *xo = x_obj;
    if (xo == NULL) {
        xo = PyFloat_FromDouble(x);
        if (xo == NULL)
            return -1;
    }
    else {
        Py_INCREF(xo);
    }
    PyObject *yo = PyFloat_FromDouble(y);
    if (yo == NULL) {
        Py_DECREF(xo);
        return -1;
    }
    args[0] = xo;
    args[1] = yo;
    PyObject *r = PyObject_Vectorcall(g_hypot, args, 2, NULL);
    Py_DECREF(xo);
    Py_DECREF(yo);
    if (r == NULL)
        return -1;
    if (!PyFloat_CheckExact(r)) {
        Py_DECREF(r);
        return -1;
    }
    *out = PyFloat_AS_DOUBLE(r);
    Py_DECREF(r);
    return 0;
}

/* cmath.sin(z) and cmath.cos(z) through the C API. 0 on success. */
static int
api_sin_cos(Py_complex z, Py_complex *s, Py_complex *c)
{
    PyObject *zo = PyComplex_FromCComplex(z);
    if (zo == NULL)
        return -1;
    PyObject *so = PyObject_CallOneArg(g_csin, zo);
    if (so == NULL) {
        Py_DECREF(zo);
        return -1;
    }
    PyObject *co = PyObject_CallOneArg(g_ccos, zo);
    Py_DECREF(zo);
    if (co == NULL) {
        Py_DECREF(so);
        return -1;
    }
    int ok = PyComplex_CheckExact(so) && PyComplex_CheckExact(co);
    if (ok) {
        *s = ((PyComplexObject *)so)->cval;
        *c = ((PyComplexObject *)co)->cval;
    }
    Py_DECREF(so);
    Py_DECREF(co);
    return ok ? 0 : -1;
}

/* cmath.phase(z) through the C API. 0 on success. */
static int
api_phase(Py_complex z, double *out)
{
    PyObject *zo = PyComplex_FromCComplex(z);
    if (zo == NULL)
        return -1;
    PyObject *r = PyObject_CallOneArg(g_cphase, zo);
    Py_DECREF(zo);
    if (r == NULL)
        return -1;
    if (!PyFloat_CheckExact(r)) {
        Py_DECREF(r);
        return -1;
    }
    *out = PyFloat_AS_DOUBLE(r);
    Py_DECREF(r);
    return 0;
}

/* A float (or float subclass such as numpy.float64) or an int as a finite double. Anything
 * else, or a non-finite value: -1 (no exception left set). */
static int
finite_arg(PyObject *o, double *out)
{
    double v;
    if (PyFloat_Check(o)) {
        v = PyFloat_AS_DOUBLE(o);
    }
    else if (PyLong_Check(o)) {
        v = PyLong_AsDouble(o);
        if (v == -1.0 && PyErr_Occurred()) {
            PyErr_Clear();
            return -1;
        }
    }
    else {
        return -1;
    }
    if (!isfinite(v))
        return -1;
    *out = v;
    return 0;
}

/* The state in a packed bytearray, or NULL (no exception set). Read the constants at once
 * (a copy): a C-API call may run Python code, which could in principle resize the bytearray. */
static tm_state *
state_of(PyObject *packed)
{
    if (!PyByteArray_CheckExact(packed)
        || PyByteArray_GET_SIZE(packed) != (Py_ssize_t)sizeof(tm_state))
        return NULL;
    return (tm_state *)PyByteArray_AS_STRING(packed);
}

static int
consts_of(PyObject *packed, tm_consts *k)
{
    const tm_state *st = state_of(packed);
    if (st == NULL)
        return -1;
    *k = st->k;
    return 0;
}

/* Complex a + b, a - b and a * b, written out (the textbook products: one rounding per real
 * product and sum; CPython's complex type computes the same formulas). */
static inline Py_complex
c_prod(Py_complex a, Py_complex b)
{
    Py_complex r;
    r.real = a.real * b.real - a.imag * b.imag;
    r.imag = a.real * b.imag + a.imag * b.real;
    return r;
}

static inline Py_complex
c_sum(Py_complex a, Py_complex b)
{
    Py_complex r;
    r.real = a.real + b.real;
    r.imag = a.imag + b.imag;
    return r;
}

static inline Py_complex
c_diff(Py_complex a, Py_complex b)
{
    Py_complex r;
    r.real = a.real - b.real;
    r.imag = a.imag - b.imag;
    return r;
}

/* Clenshaw y recurrence of _clenshaw_sum: Python's
 *     a = 2.0 * c2; y1 = y2 = 0.0
 *     for cj in reversed(coeffs): y1, y2 = a * y1 - y2 + cj, y1
 * and the derivative z recurrence of _clenshaw (with 2.0 * j * cj) when zsum is not NULL. */
static void
clenshaw(const double *coef, Py_complex c2, Py_complex *ysum, Py_complex *zsum,
         Py_complex *zprev)
{
    const Py_complex two = {2.0, 0.0};
    const Py_complex a = c_prod(two, c2);
    Py_complex y1 = {0.0, 0.0}, y2 = {0.0, 0.0};
    Py_complex z1 = {0.0, 0.0}, z2 = {0.0, 0.0};
    for (int j = NCOEF; j >= 1; j--) {
        const double cj = coef[j - 1];
        const Py_complex cjc = {cj, 0.0};
        Py_complex t = c_sum(c_diff(c_prod(a, y1), y2), cjc);
        y2 = y1;
        y1 = t;
        if (zsum != NULL) {
            const Py_complex dj = {2.0 * (double)j * cj, 0.0};
            Py_complex u = c_sum(c_diff(c_prod(a, z1), z2), dj);
            z2 = z1;
            z1 = u;
        }
    }
    *ysum = y1;
    if (zsum != NULL) {
        *zsum = z1;
        *zprev = z2;
    }
}

/* wrap_180_deg(v) then math.radians: lam (radians). 0 on success. */
static int
wrap_radians(const tm_consts *k, double v, double *lam)
{
    const double w = v_remainder(v, 360.0);
    if (isnan(w))
        return -1;
    *lam = (w == -180.0 ? 180.0 : w + 0.0) * k->deg2rad;
    return 0;
}

/* tan of the conformal latitude from tau (TMGrid._taup). 0 on success. */
static int
taup_of(const tm_consts *k, double tau, double *taup, double *tau1_out)
{
    double tau1, h;
    if (api_hypot(g_one, 1.0, tau, &tau1) < 0)
        return -1;
    if (tau1 == 0.0)
        return -1;
    const double q = k->e * tau / tau1;
    const double at = v_atanh(q);
    if (M1_BAD(at, q))
        return -1;
    const double p = k->e * at;
    const double sig = v_sinh(p);
    if (M1_BAD(sig, p))
        return -1;
    if (api_hypot(g_one, 1.0, sig, &h) < 0)
        return -1;
    *taup = tau * h - sig * tau1;
    *tau1_out = tau1;
    return 0;
}

static PyObject *
pair(double a, double b)
{
    PyObject *t = PyTuple_New(2);
    if (t == NULL)
        return NULL;
    PyObject *x = PyFloat_FromDouble(a);
    PyObject *y = PyFloat_FromDouble(b);
    if (x == NULL || y == NULL) {
        Py_XDECREF(x);
        Py_XDECREF(y);
        Py_DECREF(t);
        return NULL;
    }
    PyTuple_SET_ITEM(t, 0, x);
    PyTuple_SET_ITEM(t, 1, y);
    return t;
}

static PyObject *
bail_none(void)
{
    PyErr_Clear();
    Py_RETURN_NONE;
}

/* ------------------------------------------------------------------------------- forward */
PyDoc_STRVAR(forward_doc,
"forward(packed, lat_deg, lon_deg) -> (x m, y m) or None\n\n"
"TMGrid._forward_py: geodetic degrees to grid easting, northing (metres). None: the caller\n"
"runs the pure Python (non-float argument, non-finite value, math error).");

/* TMGrid._forward_py's numbers for finite lat, lon (degrees). 0 on success, -1: fall back. */
static int
forward_of(const tm_consts *k, double lat, double lon, double *x_out, double *y_out)
{
    double lam, xip, etap;
    if (wrap_radians(k, lon - k->cm, &lam) < 0)
        BAIL();
    const double phi = lat * k->deg2rad;
    const double cphi = v_cos(phi);
    const double clam = v_cos(lam);
    if (cphi <= 0.0) {
        xip = copysign(Py_MATH_PI / 2, lat);
        etap = 0.0;
    }
    else {
        const double tau = v_sin(phi) / cphi;
        double taup, tau1, h;
        if (taup_of(k, tau, &taup, &tau1) < 0)
            BAIL();
        xip = v_atan2(taup, clam);
        if (api_hypot(NULL, taup, clam, &h) < 0 || h == 0.0)
            BAIL();
        const double q = v_sin(lam) / h;
        etap = v_asinh(q);
        if (M1_BAD(etap, q))
            BAIL();
    }
    const Py_complex zp = {xip, etap};
    const Py_complex two = {2.0, 0.0};
    Py_complex s2, c2, y1;
    if (api_sin_cos(c_prod(two, zp), &s2, &c2) < 0)
        BAIL();
    clenshaw(k->alpha, c2, &y1, NULL, NULL);
    const Py_complex z = c_sum(zp, c_prod(s2, y1));
    *x_out = k->big_a * z.imag;
    *y_out = k->big_a * z.real;
    return 0;
bail:
    return -1;
}

static PyObject *
tm_forward(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "forward(packed, lat_deg, lon_deg)");
        return NULL;
    }
    tm_consts kk_, *k = &kk_;
    double lat, lon, x, y;
    if (consts_of(args[0], k) < 0 || finite_arg(args[1], &lat) < 0 || finite_arg(args[2], &lon) < 0)
        BAIL();
    if (forward_of(k, lat, lon, &x, &y) < 0)
        BAIL();
    return pair(x, y);
bail:
    return bail_none();
}

/* -------------------------------------------------------------------------- forward_full */
PyDoc_STRVAR(forward_full_doc,
"forward_full(packed, lat_deg, lon_deg) -> (x m, y m, gamma deg, k) or None\n\n"
"TMGrid._forward_full_py: grid position, convergence and point scale. None: the caller runs\n"
"the pure Python.");

static PyObject *
tm_forward_full(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "forward_full(packed, lat_deg, lon_deg)");
        return NULL;
    }
    tm_consts kk_, *k = &kk_;
    double lat, lon, lam, xip, etap, gam_p, k_sphere;
    if (consts_of(args[0], k) < 0 || finite_arg(args[1], &lat) < 0 || finite_arg(args[2], &lon) < 0)
        BAIL();
    if (wrap_radians(k, lon - k->cm, &lam) < 0)
        BAIL();
    const double phi = lat * k->deg2rad;
    const double sphi = v_sin(phi);
    const double cphi = v_cos(phi);
    const double clam = v_cos(lam);
    const double slam = v_sin(lam);
    if (cphi <= 0.0) {
        xip = copysign(Py_MATH_PI / 2, sphi);
        etap = 0.0;
        gam_p = sphi > 0.0 ? lam : -lam;
        k_sphere = k->k_pole;
    }
    else {
        const double tau = sphi / cphi;
        double taup, tau1, h_tc, h_1t, h_1tau;
        if (taup_of(k, tau, &taup, &tau1) < 0)
            BAIL();
        xip = v_atan2(taup, clam);
        if (api_hypot(NULL, taup, clam, &h_tc) < 0 || h_tc == 0.0)
            BAIL();
        const double q = slam / h_tc;
        etap = v_asinh(q);
        if (M1_BAD(etap, q))
            BAIL();
        if (api_hypot(g_one, 1.0, taup, &h_1t) < 0)
            BAIL();
        gam_p = v_atan2(slam * taup, clam * h_1t);
        const double rad = 1.0 - k->e_sq * sphi * sphi;
        if (rad < 0.0)
            BAIL();
        if (api_hypot(g_one, 1.0, tau, &h_1tau) < 0)
            BAIL();
        k_sphere = sqrt(rad) * h_1tau / h_tc;
    }
    const Py_complex zp = {xip, etap};
    const Py_complex two = {2.0, 0.0};
    const Py_complex one = {1.0, 0.0};
    Py_complex s2, c2, y1, z1, z2;
    if (api_sin_cos(c_prod(two, zp), &s2, &c2) < 0)
        BAIL();
    clenshaw(k->alpha, c2, &y1, &z1, &z2);
    const Py_complex s = c_prod(s2, y1);
    const Py_complex d = c_diff(c_prod(c2, z1), z2);
    const Py_complex z = c_sum(zp, s);
    const Py_complex dz = c_sum(one, d);
    double phase;
    if (api_phase(dz, &phase) < 0)
        BAIL();
    const double gamma = gam_p - phase;
    errno = 0;
    const double adz = hypot(dz.real, dz.imag); /* abs(dz) */
    if (errno == ERANGE)
        BAIL();
    const double kk = k->a_ratio * adz * k_sphere;
    PyObject *t = PyTuple_New(4);
    if (t == NULL)
        return NULL;
    const double v[4] = {k->big_a * z.imag, k->big_a * z.real, gamma * k->rad2deg, kk};
    for (int i = 0; i < 4; i++) {
        PyObject *f = PyFloat_FromDouble(v[i]);
        if (f == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, i, f);
    }
    return t;
bail:
    return bail_none();
}

/* ------------------------------------------------------------------------------- inverse */
PyDoc_STRVAR(inverse_doc,
"inverse(packed, x_m, y_m, memo=True) -> (lat deg, lon deg) or None\n\n"
"TMGrid._inverse_py: grid easting, northing (metres) to geodetic degrees. With memo True, float\n"
"arguments that are nonzero are looked up in, and added to, the packed state's ring of the\n"
"last inverses. None: the caller runs the pure Python.");

/* The inverse itself (TMGrid._inverse_py). 0 on success, -1: fall back to Python. */
static int
inverse_of(const tm_consts *k, double x, double y, double *lat_out, double *lon_out)
{
    const double big_a = k->big_a;
    const Py_complex z = {y / big_a, x / big_a};
    const Py_complex two = {2.0, 0.0};
    Py_complex s2, c2, y1;
    if (api_sin_cos(c_prod(two, z), &s2, &c2) < 0)
        BAIL();
    clenshaw(k->beta, c2, &y1, NULL, NULL);
    const Py_complex zp = c_diff(z, c_prod(s2, y1));
    const double xip = zp.real;
    const double etap = zp.imag;
    const double sxi = v_sin(xip);
    if (M1_BAD(sxi, xip))
        BAIL();
    const double cxi = v_cos(xip);
    const double she = v_sinh(etap);
    if (M1_BAD(she, etap))
        BAIL();
    double r;
    if (api_hypot(NULL, she, cxi, &r) < 0)
        BAIL();
    const double w = v_remainder(k->cm + v_atan2(she, cxi) * k->rad2deg, 360.0);
    if (isnan(w))
        BAIL();
    const double lon = w == -180.0 ? 180.0 : w + 0.0;
    *lon_out = lon;
    if (r == 0.0) {
        *lat_out = copysign(90.0, sxi);
        return 0;
    }
    const double taup = sxi / r;
    /* tau = tan(phi) from taup by Newton (TMGrid._tau_from_taup). */
    const double e2m = k->e2m;
    const double e = k->e;
    double tau = taup / e2m;
    const double at = fabs(taup);
    const double tol = 1e-15 * (at > 1.0 ? at : 1.0); /* max(1.0, abs(taup)) */
    for (int it = 0; it < 6; it++) {
        double tau1, h, hp;
        if (api_hypot(g_one, 1.0, tau, &tau1) < 0 || tau1 == 0.0)
            BAIL();
        const double q = e * tau / tau1;
        const double a = v_atanh(q);
        if (M1_BAD(a, q))
            BAIL();
        const double p = e * a;
        const double sig = v_sinh(p);
        if (M1_BAD(sig, p))
            BAIL();
        if (api_hypot(g_one, 1.0, sig, &h) < 0)
            BAIL();
        const double taupa = tau * h - sig * tau1;
        if (api_hypot(g_one, 1.0, taupa, &hp) < 0)
            BAIL();
        const double den = e2m * tau1 * hp;
        if (den == 0.0)
            BAIL();
        const double dtau = (taup - taupa) * (1.0 + e2m * tau * tau) / den;
        tau += dtau;
        if (fabs(dtau) <= tol)
            break;
    }
    *lat_out = v_atan(tau) * k->rad2deg;
    return 0;
bail:
    return -1;
}

static PyObject *
tm_inverse(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3 && nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "inverse(packed, x_m, y_m, memo=True)");
        return NULL;
    }
    tm_consts k;
    double x, y, lat, lon;
    if (consts_of(args[0], &k) < 0 || finite_arg(args[1], &x) < 0
        || finite_arg(args[2], &y) < 0)
        return bail_none();
    /* Remembered only for floats other than zero (the pure memo's rule: 0.0 == -0.0 as a key,
     * but the sign of a zero northing reaches the latitude); finite, so == is bit identity. */
    const int memo = (nargs == 3 || args[3] == Py_True) && PyFloat_CheckExact(args[1])
                     && PyFloat_CheckExact(args[2]) && x != 0.0 && y != 0.0;
    if (memo) {
        const tm_state *st = state_of(args[0]);
        for (int i = 0; i < st->n_memo; i++) {
            if (st->memo[i][0] == x && st->memo[i][1] == y)
                return pair(st->memo[i][2], st->memo[i][3]);
        }
    }
    if (inverse_of(&k, x, y, &lat, &lon) < 0)
        return bail_none();
    if (memo) {
        tm_state *st = state_of(args[0]); /* again: Python code may have run meanwhile */
        if (st != NULL) {
            double *slot = st->memo[st->next_memo];
            slot[0] = x;
            slot[1] = y;
            slot[2] = lat;
            slot[3] = lon;
            st->next_memo = (st->next_memo + 1) % MEMO;
            if (st->n_memo < MEMO)
                st->n_memo++;
        }
    }
    return pair(lat, lon);
}

/* ----------------------------------------------------------------------------- gps_input */
PyDoc_STRVAR(gps_input_doc,
"gps_input(packed, shift, to_wgs84, lat_in, lon_in, a, e2, make, weight)\n"
"    -> make(...)'s GpsInput or None\n\n"
"engine.systems.gps._gps_input_py after its checks: the record's GPS (lat_in, lon_in, floats)\n"
"through the datum shifts (shift, to_wgs84: each None or a DatumShift's transform, called as\n"
"(lat, lon, 0.0)), its WGS84 ECEF on the ellipsoid (a, e2) and\n"
"the grid of ``packed``; make(lat_in, lon_in, w_lat, w_lon, hg, ecef, lat, lon, x, y, weight).\n"
"None: the caller runs the pure Python (another kind of value, a math error, any error).");

static PyObject *g_zero; /* the float 0.0, DatumShift.transform's h_m */

/* DatumShift.transform(lat, lon, 0.0): out[3], 0; -1 (an error, or not three floats: the
 * caller falls back). */
static int
shift_point(PyObject *point, PyObject *lat, PyObject *lon, PyObject *out[3])
{
    PyObject *a[3] = {lat, lon, g_zero};
    PyObject *r = PyObject_Vectorcall(point, a, 3, NULL);
    if (r == NULL)
        return -1;
    if (!PyTuple_CheckExact(r) || PyTuple_GET_SIZE(r) != 3) {
        Py_DECREF(r);
        return -1;
    }
    for (int i = 0; i < 3; i++) {
        out[i] = PyTuple_GET_ITEM(r, i);
        if (!PyFloat_CheckExact(out[i])) { /* float() would convert it: the Python does */
            Py_DECREF(r);
            return -1;
        }
    }
    for (int i = 0; i < 3; i++)
        Py_INCREF(out[i]);
    Py_DECREF(r);
    return 0;
}

static PyObject *
tm_gps_input(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    tm_consts k;
    PyObject *shifted[3] = {NULL, NULL, NULL}, *wgs[3] = {NULL, NULL, NULL};
    PyObject *lat_o, *lon_o, *w_lat_o, *w_lon_o, *hg_o = NULL, *ecef = NULL, *res = NULL;
    PyObject *x_o = NULL, *y_o = NULL;
    double a_m, e2, w_lat, w_lon, hg, lat, lon, x, y;
    if (nargs != 9) {
        PyErr_SetString(PyExc_TypeError, "gps_input(packed, shift, to_wgs84, "
                        "lat_in, lon_in, a, e2, make, weight)");
        return NULL;
    }
    if (consts_of(args[0], &k) < 0 || !PyFloat_CheckExact(args[3])
        || !PyFloat_CheckExact(args[4]) || !PyFloat_CheckExact(args[5])
        || !PyFloat_CheckExact(args[6]))
        return bail_none();
    a_m = PyFloat_AS_DOUBLE(args[5]);
    e2 = PyFloat_AS_DOUBLE(args[6]);
    if (args[1] == Py_None) {
        lat_o = args[3];
        lon_o = args[4];
        hg = -0.0; /* -h_datum, h_datum = 0.0 */
    }
    else {
        if (shift_point(args[1], args[3], args[4], shifted) < 0)
            goto bail;
        lat_o = shifted[0];
        lon_o = shifted[1];
        hg = -PyFloat_AS_DOUBLE(shifted[2]);
    }
    if (args[2] == Py_None) {
        w_lat_o = args[3];
        w_lon_o = args[4];
    }
    else {
        if (shift_point(args[2], args[3], args[4], wgs) < 0)
            goto bail;
        w_lat_o = wgs[0];
        w_lon_o = wgs[1];
        hg = PyFloat_AS_DOUBLE(wgs[2]);
    }
    w_lat = PyFloat_AS_DOUBLE(w_lat_o);
    w_lon = PyFloat_AS_DOUBLE(w_lon_o);
    lat = PyFloat_AS_DOUBLE(lat_o);
    lon = PyFloat_AS_DOUBLE(lon_o);
    {
        /* geodetic_to_ecef(w_lat, w_lon, hg, WGS84) as gps_input writes it out */
        const double phi = w_lat * k.deg2rad;
        const double lam = w_lon * k.deg2rad;
        const double sphi = v_sin(phi);
        if (M1_BAD(sphi, phi))
            goto bail;
        const double cphi = v_cos(phi);
        if (M1_BAD(cphi, phi))
            goto bail;
        const double q = 1.0 - e2 * sphi * sphi;
        if (!(q >= 0.0) && !isnan(q)) /* math.sqrt of a negative: ValueError */
            goto bail;
        const double sq = sqrt(q);
        if (sq == 0.0)
            goto bail;
        const double nu = a_m / sq;
        const double r = (nu + hg) * cphi;
        const double clam = v_cos(lam);
        if (M1_BAD(clam, lam))
            goto bail;
        const double slam = v_sin(lam);
        if (M1_BAD(slam, lam))
            goto bail;
        ecef = Py_BuildValue("(ddd)", r * clam, r * slam, (nu * (1.0 - e2) + hg) * sphi);
        if (ecef == NULL)
            goto bail;
    }
    if (!isfinite(lat) || !isfinite(lon) || forward_of(&k, lat, lon, &x, &y) < 0)
        goto bail;
    hg_o = args[2] == Py_None ? PyFloat_FromDouble(hg) : (Py_INCREF(wgs[2]), wgs[2]);
    x_o = PyFloat_FromDouble(x);
    y_o = PyFloat_FromDouble(y);
    if (hg_o == NULL || x_o == NULL || y_o == NULL)
        goto bail;
    {
        PyObject *margs[11] = {args[3], args[4], w_lat_o, w_lon_o, hg_o, ecef, lat_o, lon_o,
                               x_o, y_o, args[8]};
        res = PyObject_Vectorcall(args[7], margs, 11, NULL);
    }
bail:
    for (int i = 0; i < 3; i++) {
        Py_XDECREF(shifted[i]);
        Py_XDECREF(wgs[i]);
    }
    Py_XDECREF(hg_o);
    Py_XDECREF(ecef);
    Py_XDECREF(x_o);
    Py_XDECREF(y_o);
    if (res == NULL)
        return bail_none();
    return res;
}

/* ---------------------------------------------------------------------------------- pack */
PyDoc_STRVAR(pack_doc,
"pack(consts) -> bytearray\n\n"
"The grid's state for forward/forward_full/inverse (its constants and an empty memo of\n"
"inverses), from a sequence of 21 floats: cm_deg,\n"
"e, e2m, A, A/a_m, e**2, the pole scale e2m**0.5*exp(e*atanh(e)), math.radians(1.0),\n"
"math.degrees(1.0), alpha_1..6, beta_1..6.");

static PyObject *
tm_pack(PyObject *self, PyObject *arg)
{
    tm_state st;
    tm_consts k;
    double *slots[9] = {&k.cm, &k.e, &k.e2m, &k.big_a, &k.a_ratio, &k.e_sq, &k.k_pole,
                        &k.deg2rad, &k.rad2deg};
    PyObject *seq = PySequence_Fast(arg, "pack() needs a sequence of floats");
    if (seq == NULL)
        return NULL;
    if (PySequence_Fast_GET_SIZE(seq) != 9 + 2 * NCOEF) {
        Py_DECREF(seq);
        PyErr_Format(PyExc_ValueError, "pack() needs %d floats", 9 + 2 * NCOEF);
        return NULL;
    }
    memset(&k, 0, sizeof k);
    PyObject **items = PySequence_Fast_ITEMS(seq);
    for (int i = 0; i < 9 + 2 * NCOEF; i++) {
        double v = PyFloat_AsDouble(items[i]);
        if (v == -1.0 && PyErr_Occurred()) {
            Py_DECREF(seq);
            return NULL;
        }
        if (i < 9)
            *slots[i] = v;
        else if (i < 9 + NCOEF)
            k.alpha[i - 9] = v;
        else
            k.beta[i - 9 - NCOEF] = v;
    }
    Py_DECREF(seq);
    memset(&st, 0, sizeof st);
    st.k = k;
    return PyByteArray_FromStringAndSize((const char *)&st, sizeof st);
}

static PyMethodDef tm_methods[] = {
    {"forward", (PyCFunction)(void (*)(void))tm_forward, METH_FASTCALL, forward_doc},
    {"forward_full", (PyCFunction)(void (*)(void))tm_forward_full, METH_FASTCALL,
     forward_full_doc},
    {"inverse", (PyCFunction)(void (*)(void))tm_inverse, METH_FASTCALL, inverse_doc},
    {"pack", tm_pack, METH_O, pack_doc},
    {"gps_input", (PyCFunction)(void (*)(void))tm_gps_input, METH_FASTCALL, gps_input_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef tm_module = {
    PyModuleDef_HEAD_INIT, "tmgrid",
    "Compiled scalar TM grid (forward, forward_full, inverse) of engine.geodesy.tmgrid: the\n"
    "same IEEE operations in the same order as the pure Python, so the same bits.",
    -1, tm_methods,
};

static PyObject *
attr_of(const char *module, const char *name)
{
    PyObject *m = PyImport_ImportModule(module);
    if (m == NULL)
        return NULL;
    PyObject *f = PyObject_GetAttrString(m, name);
    Py_DECREF(m);
    return f;
}

PyMODINIT_FUNC
PyInit_tmgrid(void)
{
    if (g_hypot == NULL) {
        g_hypot = attr_of("math", "hypot");
        g_csin = attr_of("cmath", "sin");
        g_ccos = attr_of("cmath", "cos");
        g_cphase = attr_of("cmath", "phase");
        g_one = PyFloat_FromDouble(1.0);
        g_zero = PyFloat_FromDouble(0.0);
        if (g_hypot == NULL || g_csin == NULL || g_ccos == NULL || g_cphase == NULL
            || g_one == NULL || g_zero == NULL) {
            Py_CLEAR(g_zero);
            Py_CLEAR(g_hypot);
            Py_CLEAR(g_csin);
            Py_CLEAR(g_ccos);
            Py_CLEAR(g_cphase);
            Py_CLEAR(g_one);
            return NULL;
        }
    }
    PyObject *m = PyModule_Create(&tm_module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0
        || PyModule_AddIntConstant(m, "PACKED_SIZE", (long)sizeof(tm_state)) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
