/* The engine's datum shifts, compiled (engine.native.datum): PROJ 9.5.1's own arithmetic for
 * exactly the pipelines engine.geodesy.ellipsoidal.helmert_pipeline builds, so the same bits as
 * libproj's proj_trans (tests/native/test_datum.py compares them on every datum of
 * data/TO_WGS84.DAT, on a replay's points and over the whole globe).
 *
 *   +proj=pipeline +step +proj=axisswap +order=2,1 +step +proj=unitconvert +xy_in=deg +xy_out=rad
 *   +step +proj=cart <src ellipsoid> [+step <src helmert>] [+step +inv <dst helmert>]
 *   +step +inv +proj=cart <dst ellipsoid> +step +proj=unitconvert +xy_in=rad +xy_out=deg
 *   +step +proj=axisswap +order=2,1
 *
 * The code below is transcribed from PROJ 9.5.1 (https://github.com/OSGeo/PROJ, tag 9.5.1;
 * PROJ is MIT licensed: Copyright (c) 2016 Thomas Knudsen / SDFE, (c) 2016-2018 Thomas Knudsen,
 * Kristian Evers / SDFE, (c) 2000 Frank Warmerdam, and the PROJ contributors; "Permission is
 * hereby granted, free of charge, to any person obtaining a copy of this software and associated
 * documentation files (the "Software"), to deal in the Software without restriction, including
 * without limitation the rights to use, copy, modify, merge, publish, distribute, sublicense,
 * and/or sell copies of the Software, and to permit persons to whom the Software is furnished to
 * do so, subject to the following conditions: The above copyright notice and this permission
 * notice shall be included in all copies or substantial portions of the Software." THE SOFTWARE
 * IS PROVIDED "AS IS", WITHOUT WARRANTY OF ANY KIND):
 *   - src/4D_api.cpp        proj_trans (no epoch, NaN input, direction);
 *   - src/pipeline.cpp      pipeline_forward_4d (steps in order, stop at HUGE_VAL; the pipeline
 *                           itself skips prepare/finalize);
 *   - src/fwd.cpp, inv.cpp  pj_fwd4d / pj_inv4d: fwd_prepare (latitude/longitude range checks,
 *                           clamping, adjlon, lam0, from_greenwich), fwd_finalize (fr_meter,
 *                           vfr_meter * (z + z0)), inv_prepare (to_meter), inv_finalize (lam0,
 *                           from_greenwich, adjlon);
 *   - src/adjlon.cpp        adjlon;
 *   - src/ell_set.cpp       pj_ellipsoid / pj_calc_ellipsoid_params (f = 1/rf, es = 2f - f*f,
 *                           e2s = tan(asin(sqrt(es)))^2, ra = 1/a);
 *   - src/conversions/cart.cpp        cartesian, geodetic, normal_radius_of_curvature,
 *                                     geocentric_radius;
 *   - src/transformations/helmert.cpp helmert_forward_4d/_3d, helmert_reverse_4d/_3d,
 *                                     update_parameters, build_rot_matrix (approximate, the
 *                                     position-vector transpose), ARCSEC_TO_RAD;
 *   - src/conversions/unitconvert.cpp forward_4d/_3d/_2d (x *= xy_factor, z *= z_factor);
 *   - src/conversions/axisswap.cpp    swap_xy_4d;
 *   - src/units.cpp, src/proj_internal.h  DEG_TO_RAD, PJ_EPS_LAT, M_TWOPI.
 * Same operations in the same order (built with -ffp-contract=off, as libproj has no FMA);
 * libm (sin, cos, atan, atan2, asin, tan, floor) is glibc's, the library libproj calls, through
 * volatile pointers so that gcc neither folds nor merges calls.
 *
 * A Shift object is called like engine.geodesy.ellipsoidal._ProjPoint.point (x, y, z, t,
 * direction, radians, errcheck) -> (x, y, z): it computes the forward direction (PJ_FWD) for
 * float x, y, z (finite), t None, radians and errcheck False; anything else (another direction
 * or argument type, a non-finite value, any point where PROJ would report an error) goes to the
 * fallback it was made with (the PROJ call itself), so the answer is always libproj's.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stddef.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

/* ------------------------------------------------------------------ libm, as libproj calls it */
static double (*volatile v_sin)(double) = sin;
static double (*volatile v_cos)(double) = cos;
static double (*volatile v_atan)(double) = atan;
static double (*volatile v_atan2)(double, double) = atan2;
static double (*volatile v_asin)(double) = asin;
static double (*volatile v_tan)(double) = tan;
static double (*volatile v_floor)(double) = floor;
static double (*volatile v_sqrt)(double) = sqrt;

/* src/proj_internal.h, src/units.cpp */
#define P_DEG_TO_RAD .017453292519943296
#define P_PJ_EPS_LAT 1e-12
#define P_M_PI 3.14159265358979323846
#define P_M_TWOPI 6.28318530717958647693
#define P_M_HALFPI M_PI_2
#define P_ARCSEC_TO_RAD (P_DEG_TO_RAD / 3600.0) /* helmert.cpp */

#define PJ_FWD 1

/* src/adjlon.cpp */
static double adjlon(double longitude)
{
    if (fabs(longitude) < P_M_PI + 1e-12)
        return longitude;
    longitude += P_M_PI;
    longitude -= P_M_TWOPI * v_floor(longitude / P_M_TWOPI);
    longitude -= P_M_PI;
    return longitude;
}

/* The fields of a PJ that the steps read (the defaults pj_init gives a step without +units,
 * +lon_0, +pm, +z_0: kept as run-time values so that no x + 0.0 is folded away). */
typedef struct {
    double a, es, ra, f, e2s;   /* cart's ellipsoid (ell_set.cpp) */
    double fr_meter, to_meter, vfr_meter, z0, lam0, from_greenwich;
} cart_t;

typedef struct {
    int present;
    double xyz[3];     /* Q->xyz after update_parameters */
    double refp[3];    /* Q->refp: 0 */
    double scale;      /* Q->scale (ppm) */
    double R[3][3];
    int no_rotation;
    double fr_meter, to_meter;
} helmert_t;

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    PyObject *fallback; /* _ProjPoint.point: the PROJ call */
    cart_t src, dst;
    helmert_t hsrc, hdst;
    double uc_in_xy, uc_in_z, uc_in_vfr, uc_in_z0; /* unitconvert deg -> rad (+ its finalize) */
    double uc_out_xy, uc_out_z;                    /* unitconvert rad -> deg */
} ShiftObject;

/* ------------------------------------------------------------------ set-up (ell_set.cpp) */
/* pj_ellipsoid + pj_calc_ellipsoid_params for "+a=<a> +rf=<rf>" (rf > 0) or "+a=<a> +b=<a>"
 * (rf == 0: a sphere). */
static int cart_init(cart_t *c, double a, double rf)
{
    double es, f, e, alpha, e2;
    if (!(a > 0.0) || !isfinite(a) || !(rf >= 0.0) || !isfinite(rf))
        return -1;
    if (rf > 0.0) {
        f = 1 / rf;
        es = 2 * f - f * f;
    }
    else {
        f = 0;
        es = 0;
    }
    if (!(es >= 0))
        return -1;
    /* pj_calc_ellipsoid_params (called twice by pj_init, the second time changing nothing) */
    e = v_sqrt(es);
    alpha = v_asin(e);
    e2 = v_tan(alpha);
    c->e2s = e2 * e2;
    if (0 == f)
        f = 1 - v_cos(alpha);
    if (!(f >= 0.0 && f < 1.0))
        return -1;
    if (1. - es == 0.)
        return -1;
    c->a = a;
    c->es = es;
    c->f = f;
    c->ra = 1. / a;
    c->fr_meter = c->to_meter = 1.;
    c->vfr_meter = 1.;
    c->z0 = 0.0;
    c->lam0 = 0.0;
    c->from_greenwich = 0.0;
    return 0;
}

/* PJ_TRANSFORMATION(helmert) for "+x +y +z +rx +ry +rz +s +convention=position_vector" (all
 * given, no rates, no epoch), then update_parameters and build_rot_matrix (not exact). */
static int helmert_init(helmert_t *h, const double p[7])
{
    double xyz_0[3], opk_0[3], scale_0, opk[3], f, t, pp;
    const double dxyz = 0.0, dopk = 0.0, dscale = 0.0, t_epoch = 0.0, t_obs = 0.0;
    double dt;
    int is_position_vector = 0;
    for (int i = 0; i < 7; i++)
        if (!isfinite(p[i]))
            return -1;
    xyz_0[0] = p[0];
    xyz_0[1] = p[1];
    xyz_0[2] = p[2];
    opk_0[0] = p[3] * P_ARCSEC_TO_RAD;
    opk_0[1] = p[4] * P_ARCSEC_TO_RAD;
    opk_0[2] = p[5] * P_ARCSEC_TO_RAD;
    scale_0 = p[6];
    if (scale_0 <= -1.0e6)
        return -1;
    h->no_rotation = (opk_0[0] == 0) && (opk_0[1] == 0) && (opk_0[2] == 0);
    if (!h->no_rotation)
        is_position_vector = 1;
    /* update_parameters */
    dt = t_obs - t_epoch;
    h->xyz[0] = xyz_0[0] + dxyz * dt;
    h->xyz[1] = xyz_0[1] + dxyz * dt;
    h->xyz[2] = xyz_0[2] + dxyz * dt;
    opk[0] = opk_0[0] + dopk * dt;
    opk[1] = opk_0[1] + dopk * dt;
    opk[2] = opk_0[2] + dopk * dt;
    h->scale = scale_0 + dscale * dt;
    /* build_rot_matrix, small-angle form */
    f = opk[0];
    t = opk[1];
    pp = opk[2];
    h->R[0][0] = 1;
    h->R[0][1] = pp;
    h->R[0][2] = -t;
    h->R[1][0] = -pp;
    h->R[1][1] = 1;
    h->R[1][2] = f;
    h->R[2][0] = t;
    h->R[2][1] = -f;
    h->R[2][2] = 1;
    if (is_position_vector) {
        double r;
        r = h->R[0][1];
        h->R[0][1] = h->R[1][0];
        h->R[1][0] = r;
        r = h->R[0][2];
        h->R[0][2] = h->R[2][0];
        h->R[2][0] = r;
        r = h->R[1][2];
        h->R[1][2] = h->R[2][1];
        h->R[2][1] = r;
    }
    h->refp[0] = h->refp[1] = h->refp[2] = 0.0;
    h->fr_meter = h->to_meter = 1.;
    h->present = 1;
    return 0;
}

/* ------------------------------------------------------------------ cart.cpp */
static double normal_radius_of_curvature(double a, double es, double sinphi)
{
    if (es == 0)
        return a;
    return a / v_sqrt(1 - es * sinphi * sinphi);
}

static double geocentric_radius(double a, double b_div_a, double cosphi, double sinphi)
{
    const double cosphi_squared = cosphi * cosphi;
    const double sinphi_squared = sinphi * sinphi;
    const double b_div_a_squared = b_div_a * b_div_a;
    const double b_div_a_squared_mul_sinphi_squared = b_div_a_squared * sinphi_squared;
    return a * v_sqrt((cosphi_squared + b_div_a_squared * b_div_a_squared_mul_sinphi_squared)
                      / (cosphi_squared + b_div_a_squared_mul_sinphi_squared));
}

static void cartesian(double v[3], const cart_t *P)
{
    const double lam = v[0], phi = v[1], z = v[2];
    const double cosphi = v_cos(phi);
    const double sinphi = v_sin(phi);
    const double N = normal_radius_of_curvature(P->a, P->es, sinphi);
    v[0] = (N + z) * cosphi * v_cos(lam);
    v[1] = (N + z) * cosphi * v_sin(lam);
    v[2] = (N * (1 - P->es) + z) * sinphi;
}

static void geodetic(double v[3], const cart_t *P)
{
    const double cx = v[0], cy = v[1], cz = v[2];
    double phi, lam, h;
    const double x_div_a = cx * P->ra;
    const double y_div_a = cy * P->ra;
    const double z_div_a = cz * P->ra;
    const double p_div_a = v_sqrt(x_div_a * x_div_a + y_div_a * y_div_a);
    const double b_div_a = 1 - P->f;
    const double p_div_a_b_div_a = p_div_a * b_div_a;
    const double norm = v_sqrt(z_div_a * z_div_a + p_div_a_b_div_a * p_div_a_b_div_a);
    double c, s;
    if (norm != 0) {
        const double inv_norm = 1.0 / norm;
        c = p_div_a_b_div_a * inv_norm;
        s = z_div_a * inv_norm;
    }
    else {
        c = 1;
        s = 0;
    }
    const double y_phi = z_div_a + P->e2s * b_div_a * s * s * s;
    const double x_phi = p_div_a - P->es * c * c * c;
    const double norm_phi = v_sqrt(y_phi * y_phi + x_phi * x_phi);
    double cosphi, sinphi;
    if (norm_phi != 0) {
        const double inv_norm_phi = 1.0 / norm_phi;
        cosphi = x_phi * inv_norm_phi;
        sinphi = y_phi * inv_norm_phi;
    }
    else {
        cosphi = 1;
        sinphi = 0;
    }
    if (x_phi <= 0) {
        phi = cz >= 0 ? P_M_HALFPI : -P_M_HALFPI;
        cosphi = 0;
        sinphi = cz >= 0 ? 1 : -1;
    }
    else {
        phi = v_atan(y_phi / x_phi);
    }
    lam = v_atan2(y_div_a, x_div_a);
    if (cosphi < 1e-6) {
        const double r = geocentric_radius(P->a, b_div_a, cosphi, sinphi);
        h = fabs(cz) - r;
    }
    else {
        const double N = normal_radius_of_curvature(P->a, P->es, sinphi);
        h = P->a * p_div_a / cosphi - N;
    }
    v[0] = lam;
    v[1] = phi;
    v[2] = h;
}

/* pj_fwd4d on cart (left RADIANS, right CARTESIAN); -1 where PROJ gives an error. */
static int cart_fwd4d(double v[3], const cart_t *P)
{
    double t;
    if (HUGE_VAL == v[0] || HUGE_VAL == v[1] || HUGE_VAL == v[2])
        return -1;
    /* fwd_prepare, PJ_IO_UNITS_RADIANS */
    t = (v[1] < 0 ? -v[1] : v[1]) - P_M_HALFPI;
    if (t > P_PJ_EPS_LAT)
        return -1;
    if (v[0] > 10 || v[0] < -10)
        return -1;
    if (v[1] > P_M_HALFPI)
        v[1] = P_M_HALFPI;
    if (v[1] < -P_M_HALFPI)
        v[1] = -P_M_HALFPI;
    v[0] = adjlon(v[0]); /* P->over == 0 */
    v[0] = (v[0] - P->from_greenwich) - P->lam0;
    v[0] = adjlon(v[0]);
    if (HUGE_VAL == v[0])
        return -1;
    cartesian(v, P); /* fwd3d */
    if (HUGE_VAL == v[0])
        return -1;
    /* fwd_finalize, PJ_IO_UNITS_CARTESIAN */
    v[0] *= P->fr_meter;
    v[1] *= P->fr_meter;
    v[2] *= P->fr_meter;
    return 0;
}

/* pj_inv4d on cart: CARTESIAN -> RADIANS. */
static int cart_inv4d(double v[3], const cart_t *P)
{
    if (v[0] == HUGE_VAL || v[1] == HUGE_VAL || v[2] == HUGE_VAL)
        return -1;
    /* inv_prepare, PJ_IO_UNITS_CARTESIAN */
    v[0] *= P->to_meter;
    v[1] *= P->to_meter;
    v[2] *= P->to_meter;
    geodetic(v, P); /* inv3d */
    if (HUGE_VAL == v[0])
        return -1;
    /* inv_finalize, PJ_IO_UNITS_RADIANS */
    v[0] = v[0] + P->from_greenwich + P->lam0;
    v[0] = adjlon(v[0]);
    return 0;
}

/* ------------------------------------------------------------------ helmert.cpp */
/* pj_fwd4d on helmert (CARTESIAN both sides; t = HUGE_VAL: t_obs = t_epoch, no rebuild). */
static int helmert_fwd4d(double v[3], const helmert_t *Q)
{
    double X, Y, Z, scale;
    if (HUGE_VAL == v[0] || HUGE_VAL == v[1] || HUGE_VAL == v[2])
        return -1;
    if (Q->no_rotation && Q->scale == 0) {
        v[0] = v[0] + Q->xyz[0];
        v[1] = v[1] + Q->xyz[1];
        v[2] = v[2] + Q->xyz[2];
    }
    else {
        scale = 1 + Q->scale * 1e-6;
        X = v[0] - Q->refp[0];
        Y = v[1] - Q->refp[1];
        Z = v[2] - Q->refp[2];
        v[0] = scale * (Q->R[0][0] * X + Q->R[0][1] * Y + Q->R[0][2] * Z);
        v[1] = scale * (Q->R[1][0] * X + Q->R[1][1] * Y + Q->R[1][2] * Z);
        v[2] = scale * (Q->R[2][0] * X + Q->R[2][1] * Y + Q->R[2][2] * Z);
        v[0] += Q->xyz[0];
        v[1] += Q->xyz[1];
        v[2] += Q->xyz[2];
    }
    if (HUGE_VAL == v[0])
        return -1;
    v[0] *= Q->fr_meter;
    v[1] *= Q->fr_meter;
    v[2] *= Q->fr_meter;
    return 0;
}

/* pj_inv4d on helmert. */
static int helmert_inv4d(double v[3], const helmert_t *Q)
{
    double X, Y, Z, scale;
    if (v[0] == HUGE_VAL || v[1] == HUGE_VAL || v[2] == HUGE_VAL)
        return -1;
    v[0] *= Q->to_meter;
    v[1] *= Q->to_meter;
    v[2] *= Q->to_meter;
    if (Q->no_rotation && Q->scale == 0) {
        v[0] = v[0] - Q->xyz[0];
        v[1] = v[1] - Q->xyz[1];
        v[2] = v[2] - Q->xyz[2];
    }
    else {
        scale = 1 + Q->scale * 1e-6;
        X = (v[0] - Q->xyz[0]) / scale;
        Y = (v[1] - Q->xyz[1]) / scale;
        Z = (v[2] - Q->xyz[2]) / scale;
        v[0] = (Q->R[0][0] * X + Q->R[1][0] * Y + Q->R[2][0] * Z) + Q->refp[0];
        v[1] = (Q->R[0][1] * X + Q->R[1][1] * Y + Q->R[2][1] * Z) + Q->refp[1];
        v[2] = (Q->R[0][2] * X + Q->R[1][2] * Y + Q->R[2][2] * Z) + Q->refp[2];
    }
    if (HUGE_VAL == v[0])
        return -1;
    return 0;
}

/* ------------------------------------------------------------------ the pipeline */
/* proj_trans(P, PJ_FWD, (x, y, z, HUGE_VAL)) of the pipeline: out[3]; -1 where PROJ would report
 * an error or the input is not finite (the caller then asks PROJ itself). */
static int shift_fwd(const ShiftObject *S, double x, double y, double z, double out[3])
{
    double v[3];
    if (!isfinite(x) || !isfinite(y) || !isfinite(z))
        return -1; /* NaN: proj_trans's coord_has_nans; HUGE_VAL: errors */
    /* axisswap +order=2,1 (swap_xy_4d, prepare/finalize skipped) */
    v[0] = y;
    v[1] = x;
    v[2] = z;
    /* unitconvert deg -> rad: skip_fwd_prepare; forward_4d; fwd_finalize (right RADIANS) */
    v[0] *= S->uc_in_xy;
    v[1] *= S->uc_in_xy;
    v[2] *= S->uc_in_z;
    if (HUGE_VAL == v[0])
        return -1;
    v[2] = S->uc_in_vfr * (v[2] + S->uc_in_z0);
    if (v[0] == HUGE_VAL)
        return -1;
    if (cart_fwd4d(v, &S->src) < 0)
        return -1;
    if (S->hsrc.present && helmert_fwd4d(v, &S->hsrc) < 0)
        return -1;
    if (S->hdst.present && helmert_inv4d(v, &S->hdst) < 0)
        return -1;
    if (cart_inv4d(v, &S->dst) < 0)
        return -1;
    /* unitconvert rad -> deg: forward_4d; fwd_finalize (right DEGREES): nothing */
    v[0] *= S->uc_out_xy;
    v[1] *= S->uc_out_xy;
    v[2] *= S->uc_out_z;
    if (HUGE_VAL == v[0])
        return -1;
    /* axisswap */
    out[0] = v[1];
    out[1] = v[0];
    out[2] = v[2];
    if (!isfinite(out[0]) || !isfinite(out[1]) || !isfinite(out[2]))
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
    if (kwnames == NULL && nargs == 7 && PyFloat_CheckExact(args[0])
        && PyFloat_CheckExact(args[1]) && PyFloat_CheckExact(args[2]) && args[3] == Py_None
        && PyLong_CheckExact(args[4]) && args[5] == Py_False && args[6] == Py_False) {
        int overflow = 0;
        long direction = PyLong_AsLongAndOverflow(args[4], &overflow);
        if (direction == PJ_FWD && !overflow
            && shift_fwd(S, PyFloat_AS_DOUBLE(args[0]), PyFloat_AS_DOUBLE(args[1]),
                         PyFloat_AS_DOUBLE(args[2]), out) == 0)
            return triple(out);
        if (PyErr_Occurred())
            return NULL;
    }
    return PyObject_Vectorcall(S->fallback, args, nargsf, kwnames);
}

PyDoc_STRVAR(forward_doc,
"forward(x, y, z) -> (x, y, z) or None\n\n"
"The pipeline's forward direction computed here (floats: lat deg, lon deg, h m on the source\n"
"datum -> the same on the destination), or None where this kernel declines (the PROJ call\n"
"then answers). For the tests.");

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
        PyErr_SetString(PyExc_ValueError, "helmert parameters PROJ would refuse");
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
    if (cart_init(&S->src, a_src, rf_src) < 0 || cart_init(&S->dst, a_dst, rf_dst) < 0) {
        Py_DECREF(S);
        PyErr_SetString(PyExc_ValueError, "an ellipsoid PROJ would refuse");
        return NULL;
    }
    if (helmert_arg(h_src, &S->hsrc) < 0 || helmert_arg(h_dst, &S->hdst) < 0) {
        Py_DECREF(S);
        return NULL;
    }
    /* unitconvert +xy_in=deg +xy_out=rad: xy_factor = DEG_TO_RAD / 1.0, z_factor 1.0; its
     * fwd_finalize (right RADIANS) with vfr_meter 1, z0 0. +xy_in=rad +xy_out=deg: 1.0 / DEG */
    {
        double f = P_DEG_TO_RAD;
        S->uc_in_xy = f;
        S->uc_in_xy /= 1.0;
        S->uc_in_z = 1.0;
        S->uc_in_vfr = 1.;
        S->uc_in_z0 = 0.0;
        S->uc_out_xy = 1.0;
        S->uc_out_xy /= f;
        S->uc_out_z = 1.0;
    }
    return (PyObject *)S;
}

static PyMethodDef shift_methods[] = {
    {"forward", shift_forward, METH_VARARGS, forward_doc},
    {NULL, NULL, 0, NULL}
};

static PyGetSetDef shift_getset[] = {
    {"fallback", shift_get_fallback, NULL, "the PROJ call for what this kernel declines", NULL},
    {NULL, NULL, NULL, NULL, NULL}
};

PyDoc_STRVAR(shift_doc,
"Shift(fallback, a_src, rf_src, helmert_src, a_dst, rf_dst, helmert_dst)\n\n"
"helmert_pipeline(src, dst)'s PROJ transformation computed as libproj 9.5.1 computes it.\n"
"Called as _ProjPoint.point: (x, y, z, t, direction, radians, errcheck) -> (x, y, z)\n"
"(lat deg, lon deg, h m); ``fallback`` (that PROJ call) answers what it does not cover.\n"
"rf 0.0: a sphere (+b=a); a helmert: None (omitted step) or (x, y, z, rx, ry, rz, s).");

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
    "helmert_pipeline's PROJ transformations, compiled (PROJ 9.5.1's arithmetic, MIT).", -1,
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
