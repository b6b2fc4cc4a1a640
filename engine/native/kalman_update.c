/* The numeric core of the filter's measurement update (engine/filter/update.py), compiled.
 *
 * update(): v = z - H x (angle rows wrapped), S = H P Hᵀ + R, Cholesky S = L Lᵀ (SciPy's dpotrf),
 * one forward substitution L Y = [HP | v | I] (SciPy's dtrsm), K = (L⁻¹HP)ᵀ L⁻¹,
 * x⁺ = x + (L⁻¹HP)ᵀ w (heading wrapped to [0, 2π)), P⁺ by the Joseph form or P - K HP,
 * symmetrised, and the NIS wᵀw. distance(): the Mahalanobis length of a block of the innovation
 * (update.innovation_distance).
 *
 * Bits: every numpy product goes through np_dot below, a transcription of the float64 branches
 * of numpy's cblas_matrixproduct (numpy/_core/src/common/cblasfuncs.c: the same routine —
 * daxpy, DOUBLE_dot's 0.0 + ddot, gemv, gemm or syrk — with the same order, transposition flags
 * and leading dimensions numpy derives from the operands' shapes and contiguity), and the LAPACK
 * calls are the ones SciPy's f2py wrappers make (flapack dpotrf with clean=1, fblas dtrsm), on
 * the same Fortran-ordered copies. The elementwise steps are written in the order of the
 * Python. Built with -ffp-contract=off (setup.py): no fused multiply-add.
 *
 * The caller allocates the outputs (numpy arrays, C-contiguous; Y C-contiguous (n+1+p)×p, i.e.
 * the Fortran-ordered p×(n+1+p) the Python's trsm overwrites) and wraps them; any input that is
 * not a C-contiguous float64 array of the expected shape, a non-finite angle innovation, S not
 * positive definite or borderline (factor_borderline), or a variance not above VARIANCE_FLOOR·κ of
 * its prior gives None: the caller then runs the Python, which raises what it raises. update_new() is update() with the outputs made here (numpy.empty)
 * and returned, x⁺ and P⁺ (and t when filled) already read-only: one call instead of seven
 * numpy.empty and three setflags calls in the Python per update.
 */
#include "uvn_linalg.h"

#include <math.h>
#include <string.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

static const uvn_linalg_t blas = UVN_LINALG;
static const int bound = 1;

static const double TWO_PI = 2.0 * 3.14159265358979311599796346854;  /* 2.0 * math.pi */
static const double PI = 3.14159265358979311599796346854;            /* math.pi */

/* ------------------------------------------------------------------ numpy arrays made here */

#include "uvn_numpy.h"

/* ------------------------------------------------------------------ numpy's dot, float64 */

typedef struct {
    const double *d;
    int nd;
    int64_t dim[2];
    int64_t st[2]; /* strides in elements */
} arr_t;

enum { SH_SCALAR, SH_COLUMN, SH_ROW, SH_MATRIX };

static arr_t mk1(const double *d, int64_t n, int64_t st)
{
    arr_t a = {d, 1, {n, 0}, {st, 0}};
    return a;
}

static arr_t mk2(const double *d, int64_t r, int64_t c, int64_t sr, int64_t sc)
{
    arr_t a = {d, 2, {r, c}, {sr, sc}};
    return a;
}

/* numpy's relaxed C / F contiguity (dimensions of length 1 ignored; a 0-length one: both). */
static int is_c(const arr_t *a)
{
    int64_t sd = 1;
    for (int i = a->nd - 1; i >= 0; i--) {
        if (a->dim[i] == 0)
            return 1;
        if (a->dim[i] != 1) {
            if (a->st[i] != sd)
                return 0;
            sd *= a->dim[i];
        }
    }
    return 1;
}

static int is_f(const arr_t *a)
{
    int64_t sd = 1;
    for (int i = 0; i < a->nd; i++) {
        if (a->dim[i] == 0)
            return 1;
        if (a->dim[i] != 1) {
            if (a->st[i] != sd)
                return 0;
            sd *= a->dim[i];
        }
    }
    return 1;
}

static int shape_of(const arr_t *a)
{
    if (a->nd == 1)
        return a->dim[0] > 1 ? SH_COLUMN : SH_SCALAR;
    if (a->dim[0] > 1)
        return a->dim[1] == 1 ? SH_COLUMN : SH_MATRIX;
    return a->dim[1] == 1 ? SH_SCALAR : SH_ROW;
}

static int64_t max1(int64_t k) { return k > 1 ? k : 1; }

/* numpy's DOUBLE_dot: 0.0 + cblas_ddot (one chunk: n is small). */
static double np_vdot(int64_t n, const double *x, int64_t incx, const double *y, int64_t incy)
{
    double sum = 0.;
    sum += blas.ddot(n, x, incx, y, incy);
    return sum;
}

/* out (C-contiguous, `size` elements, zeroed here) = numpy.dot(a, b) for 1-/2-d float64
 * operands with positive strides, as cblas_matrixproduct computes it. Returns 0, or -1 for a
 * layout numpy would first copy (not used by the callers here). */
static int np_dot(const arr_t *ap1, const arr_t *ap2, double *out, int64_t size)
{
    const arr_t *a = ap1, *b = ap2;
    int s1 = shape_of(ap1), s2 = shape_of(ap2);
    int64_t l, a1stride = 0, odim1 = 1;

    memset(out, 0, (size_t)size * sizeof(double));
    if (s1 == SH_SCALAR || s2 == SH_SCALAR) {
        const arr_t *oa = ap1, *ob = ap2;
        int nd;
        if (s1 == SH_SCALAR) {
            a = ap2;
            b = ap1;
            s1 = s2;
            s2 = SH_SCALAR;
        }
        a1stride = (s1 == SH_ROW) ? a->st[1] : a->st[0];
        l = oa->dim[oa->nd - 1];
        nd = a->nd + b->nd - 2;
        if (nd == 1) {
            l = (oa->nd == 2) ? oa->dim[0] : ob->dim[1];
        }
        else if (nd == 2) {
            odim1 = ob->dim[1];
            l = (s1 == SH_ROW) ? ob->dim[1] : oa->dim[0];
        }
        if (oa->dim[oa->nd - 1] == 0)
            l = 0;
    }
    else {
        l = a->dim[a->nd - 1];
    }
    if (size == 0 || l == 0)
        return 0;

    if (s2 == SH_SCALAR) {
        if (l == 1)
            out[0] = b->d[0] * a->d[0];
        else if (s1 != SH_MATRIX)
            blas.daxpy(l, b->d[0], a->d, a1stride, out, 1);
        else
            return -1; /* (matrix × 1×1 cannot be aligned; numpy's loop is not needed) */
        (void)odim1;
    }
    else if (s2 == SH_COLUMN && s1 != SH_MATRIX) {
        out[0] = np_vdot(l, a->d, a->st[s1 == SH_ROW], b->d, b->st[0]);
    }
    else if (s1 == SH_MATRIX && s2 != SH_MATRIX) {
        int order;
        int64_t lda;
        if (is_c(a)) {
            order = UvnRowMajor;
            lda = max1(a->dim[1]);
        }
        else if (is_f(a)) {
            order = UvnColMajor;
            lda = max1(a->dim[0]);
        }
        else
            return -1;
        blas.dgemv(order, UvnNoTrans, a->dim[0], a->dim[1], 1., a->d, lda, b->d, b->st[0], 0.,
                   out, 1);
    }
    else if (s1 != SH_MATRIX && s2 == SH_MATRIX) {
        int order;
        int64_t lda, a1s;
        if (is_c(b)) {
            order = UvnRowMajor;
            lda = max1(b->dim[1]);
        }
        else if (is_f(b)) {
            order = UvnColMajor;
            lda = max1(b->dim[0]);
        }
        else
            return -1;
        a1s = (s1 == SH_ROW) ? a->st[1] : a->st[0];
        blas.dgemv(order, UvnTrans, b->dim[0], b->dim[1], 1., b->d, lda, a->d, a1s, 0., out, 1);
    }
    else {
        int t1 = UvnNoTrans, t2 = UvnNoTrans;
        int64_t L, N, M, lda, ldb, ldc;
        int c1 = is_c(a), f1 = is_f(a), c2 = is_c(b), f2 = is_f(b);
        if ((!c1 && !f1) || (!c2 && !f2) || a->nd != 2 || b->nd != 2)
            return -1;
        L = a->dim[0];
        N = b->dim[1];
        M = b->dim[0];
        lda = max1(a->dim[1]);
        ldb = max1(b->dim[1]);
        ldc = max1(N);
        if (f1) {
            t1 = UvnTrans;
            lda = max1(a->dim[0]);
        }
        if (f2) {
            t2 = UvnTrans;
            ldb = max1(b->dim[0]);
        }
        if (a->d == b->d && a->dim[0] == b->dim[1] && a->dim[1] == b->dim[0] &&
            a->st[0] == b->st[1] && a->st[1] == b->st[0] &&
            ((t1 == UvnTrans) ^ (t2 == UvnTrans)) && ((t1 == UvnNoTrans) ^ (t2 == UvnNoTrans))) {
            if (t1 == UvnNoTrans)
                blas.dsyrk(UvnRowMajor, UvnUpper, t1, N, M, 1., a->d, lda, 0., out, ldc);
            else
                blas.dsyrk(UvnRowMajor, UvnUpper, t1, N, M, 1., b->d, ldb, 0., out, ldc);
            for (int64_t i = 0; i < N; i++)
                for (int64_t j = i + 1; j < N; j++)
                    out[j * N + i] = out[i * N + j];
        }
        else {
            blas.dgemm(UvnRowMajor, t1, t2, L, N, M, 1., a->d, lda, b->d, ldb, 0., out, ldc);
        }
    }
    return 0;
}

/* ------------------------------------------------------------------ SciPy's f2py wrappers */

/* lapack.dpotrf(S, lower=1, clean=1) on the m×m block of a row-major matrix at s with row
 * stride ld: the Fortran-ordered copy f is factorised in place, its upper triangle zeroed.
 * Returns info. */
static int sp_potrf_lower(const double *s, int64_t ld, int m, double *f)
{
    int info = 0;
    for (int j = 0; j < m; j++)
        for (int i = 0; i < m; i++)
            f[i + (int64_t)j * m] = s[i * ld + j];
    blas.dpotrf("L", &m, f, &m, &info);
    for (int i = 0; i < m; i++)
        for (int j = i + 1; j < m; j++)
            f[(int64_t)j * m + i] = 0.0;
    return info;
}

/* ------------------------------------------------------------------ the decline rule */

/* Where rounding may decide a discrete outcome, the kernel declines and the reference decides
 * (docs/PERFORMANCE.md, "The tolerance contract"): this kernel's Cholesky and LAPACK's round
 * differently, so at the boundary of positive definiteness the two may disagree on whether S
 * factorises, whether a variance stays positive, and (S near-singular) on the LOM verdict and
 * the LS flags, whose values then carry no digits. */

/* A pivot d_k = L_kk² is S_kk - Σ_j L_kj² with Σ_j L_kj² ≤ S_kk: its rounding error is about
 * (k+1)·ε·S_kk (≤ 2.2e-15·S_kk for 9 rows, ε = 2.2e-16). Below PIVOT_FLOOR·S_kk (some 50 times
 * that) the sign of the pivot, i.e. whether S factorises, is rounding's choice. The same floor
 * on d_min / d_max, a lower bound of cond(S), declines S with cond(S) > 1e13, where the forward
 * error of S⁻¹v (cond(S)·ε ≳ 1e-3) leaves the statistics no digits to compare. */
#define PIVOT_FLOOR 1e-13

/* After the update a variance P⁺_ii = P_ii - (K H P)_ii (or Joseph's sum) is a difference whose
 * rounding differs between the kernel and the reference by up to about cond(S)·ε·P_ii (measured
 * on the random updates of tests/native/test_kalman_update.py: 1.2e-8·P_ii at cond(S) = 2.7e8).
 * cond(S) ≤ κ = tr(S)·tr(S⁻¹) ≤ p²·cond(S), tr(S⁻¹) = ‖L⁻¹‖²_F from the L⁻¹ the update has
 * anyway; at or below VARIANCE_FLOOR·κ·P_ii (some 450·κ·ε) the sign of P⁺_ii, divergence or
 * not, is rounding's choice. */
#define VARIANCE_FLOOR 1e-13

/* 1 if the factor L (Fortran m×m at f) of the m×m block at s (row stride ld) is borderline:
 * a pivot L_kk² ≤ PIVOT_FLOOR·S_kk, or min L_kk² ≤ PIVOT_FLOOR·max L_kk² (NaN: borderline). */
static int factor_borderline(const double *s, int64_t ld, int m, const double *f)
{
    double dmin = HUGE_VAL, dmax = 0.0;
    for (int k = 0; k < m; k++) {
        double d = f[k + (int64_t)k * m] * f[k + (int64_t)k * m];
        if (!(d > PIVOT_FLOOR * s[k * ld + k]))
            return 1;
        if (d < dmin)
            dmin = d;
        if (d > dmax)
            dmax = d;
    }
    return !(dmin > PIVOT_FLOOR * dmax);
}

/* blas.dtrsm(1.0, L, B, side=0, lower=1, trans_a=0, diag=0): B (Fortran, m×ncol) ← L⁻¹B. */
static void sp_trsm_lower(const double *l, int m, double *b, int ncol)
{
    const double one = 1.0;
    blas.dtrsm("L", "L", "N", "N", &m, &ncol, &one, l, &m, b, &m);
}

/* ------------------------------------------------------------------ Python's scalars */

/* engine.geodesy.angles.wrap_pi: fmod(a + π, 2π), + 2π if ≤ 0, − π. */
static double wrap_pi(double angle)
{
    double a = fmod(angle + PI, TWO_PI);
    if (a <= 0.0)
        a += TWO_PI;
    return a - PI;
}

/* numpy's float64 % 2π (npy_remainder; the same as Python's float %). */
static double rem_2pi(double a)
{
    double mod = fmod(a, TWO_PI);
    if (mod) {
        if ((TWO_PI < 0) != (mod < 0))
            mod += TWO_PI;
    }
    else {
        mod = copysign(0.0, TWO_PI);
    }
    return mod;
}

/* ------------------------------------------------------------------ buffers */

typedef struct {
    Py_buffer v[12];
    int n;
} bufs_t;

static void release(bufs_t *bs)
{
    for (int i = 0; i < bs->n; i++)
        PyBuffer_Release(&bs->v[i]);
    bs->n = 0;
}

/* A C-contiguous float64 buffer of `obj` with ndim `nd` and shape (d0[, d1]) (d < 0: any),
 * or NULL (no exception left set). A numpy float64 array to read is read directly
 * (np_direct), as its buffer would give it. */
static double *get(bufs_t *bs, PyObject *obj, int nd, int64_t d0, int64_t d1, int writable)
{
    Py_buffer *v = &bs->v[bs->n];
    np_fields_t *f;
    if (!writable && (f = np_direct(obj, nd)) != NULL) {
        /* numpy's own array: its fields, as its buffer would give them (nothing to release) */
        if (!(PyArray_FLAGS(f) & NP_C_CONTIGUOUS))
            return NULL; /* numpy would refuse the C-contiguous buffer */
        v->obj = NULL;
        v->buf = PyArray_BYTES(f);
        v->ndim = nd;
        v->shape = PyArray_DIMS(f);
        v->strides = PyArray_STRIDES(f);
        v->itemsize = 8;
        bs->n++;
        if ((d0 >= 0 && v->shape[0] != d0) || (nd == 2 && d1 >= 0 && v->shape[1] != d1))
            return NULL;
        return (double *)v->buf;
    }
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, v, flags) != 0) {
        PyErr_Clear();
        return NULL;
    }
    bs->n++;
    if (v->itemsize != 8 || v->format == NULL || strcmp(v->format, "d") != 0 ||
        v->ndim != nd || (d0 >= 0 && v->shape[0] != d0) ||
        (nd == 2 && d1 >= 0 && v->shape[1] != d1))
        return NULL;
    return (double *)v->buf;
}

/* ------------------------------------------------------------------ update */

/* LsTest.t: lt = L⁻¹ᵀ (C p×p at li, row stride p), t = lt.dot(w) / np.sqrt(np.add.reduce(lt * lt,
 * axis=1)). numpy's add.reduce of a row of fewer than 8 items is 0.0 + (((-0.0 + a0) + a1) + …)
 * (pairwise_sum's short case); 8 or more (pairwise blocks) are left to the Python, and so is any
 * non-finite step (where numpy would warn). Returns 1 if t was filled. */
static int ls_t(const double *li, const double *w, int64_t p, double *t)
{
    double num[8];
    arr_t alt = mk2(li, p, p, p, 1), aw = mk1(w, p, 1);
    if (p >= 8 || np_dot(&alt, &aw, num, p))
        return 0;
    for (int64_t i = 0; i < p; i++) {
        double res = -0.0, sum = 0.0;
        for (int64_t j = 0; j < p; j++) {
            double sq = li[i * p + j] * li[i * p + j];
            if (!isfinite(sq))
                return 0;
            res += sq;
        }
        sum += res;
        double root = sqrt(sum);
        if (!isfinite(num[i]) || !isfinite(root))
            return 0;
        t[i] = num[i] / root;
        if (!isfinite(t[i]))
            return 0;
    }
    return 1;
}

/* Scratch doubles update_core() keeps on the stack (16 KiB: n ≤ 18 states with p ≤ 8 rows). */
#define UPDATE_STACK_WORK 2048

/* The update of update() / update_new() on checked inputs (H p×n, x n, P n×n, z p, R p×p)
 * into the outputs Y, v, S, K, xn, Pn, t_ls: 1 with *nis and *t_ok set, 0 for the Python to run
 * instead (no exception), -1 on an error (exception set). */
static int update_core(const double *x, const double *P, const double *H, const double *z,
                       const double *R, int64_t p, int64_t n, PyObject *angle_rows, int joseph,
                       Py_ssize_t ipsi, double *Y, double *v, double *S, double *K, double *xn,
                       double *Pn, double *t_ls, double *nis_out, int *t_ok_out)
{
    int status = 0;
    /* scratch: Hx p, HP p·n, L p·p, t n, KH, A, AP, Pj, KRKt n·n each, KR n·p; on the stack
     * for the cycle's sizes (a heap block of this size is a malloc/free per update) */
    double stack_work[UPDATE_STACK_WORK];
    size_t need = (size_t)(p + p * n + p * p + n + 5 * n * n + n * p);
    double *work = need <= UPDATE_STACK_WORK ? stack_work : PyMem_Malloc(sizeof(double) * need);
    if (work == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    double *Hx = work, *HP = Hx + p, *Lf = HP + p * n, *t = Lf + p * p, *KH = t + n;
    double *A = KH + n * n, *AP = A + n * n, *Pj = AP + n * n, *KRKt = Pj + n * n;
    double *KR = KRKt + n * n;

    arr_t aH = mk2(H, p, n, n, 1), ax = mk1(x, n, 1), aP = mk2(P, n, n, n, 1);

    /* v = z - H.dot(x); v[i] = wrap_pi(v[i]) for i in angle_rows */
    if (np_dot(&aH, &ax, Hx, p))
        goto fallback;
    for (int64_t i = 0; i < p; i++)
        v[i] = z[i] - Hx[i];
    {
        PyObject *seq = PySequence_Fast(angle_rows, "angle_rows must be a sequence");
        if (seq == NULL) {
            status = -1;
            goto done;
        }
        Py_ssize_t na = PySequence_Fast_GET_SIZE(seq);
        PyObject **items = PySequence_Fast_ITEMS(seq);
        int bad = 0;
        for (Py_ssize_t k = 0; k < na && !bad; k++) {
            if (PyBool_Check(items[k])) { /* numpy reads v[True] as a mask: the Python's case */
                bad = 1;
                break;
            }
            Py_ssize_t i = PyNumber_AsSsize_t(items[k], NULL);
            if (i == -1 && PyErr_Occurred()) {
                PyErr_Clear();
                bad = 1;
                break;
            }
            if (i < 0)
                i += p;
            if (i < 0 || i >= p || !isfinite(v[i] + PI)) {
                bad = 1;
                break;
            }
            v[i] = wrap_pi(v[i]);
        }
        Py_DECREF(seq);
        if (bad)
            goto fallback;
    }

    /* HP = H.dot(P); S = HP.dot(H.T); S += R */
    arr_t aHP = mk2(HP, p, n, n, 1), aHt = mk2(H, n, p, 1, n);
    if (np_dot(&aH, &aP, HP, p * n) || np_dot(&aHP, &aHt, S, p * p))
        goto fallback;
    for (int64_t i = 0; i < p * p; i++)
        S[i] = S[i] + R[i];

    /* L = dpotrf(S, 1, 1); Y = dtrsm(1.0, L, [HP | v | I]) in place */
    if (sp_potrf_lower(S, p, (int)p, Lf) != 0 || factor_borderline(S, p, (int)p, Lf))
        goto fallback;
    for (int64_t j = 0; j < n; j++)
        for (int64_t i = 0; i < p; i++)
            Y[j * p + i] = HP[i * n + j];
    for (int64_t i = 0; i < p; i++)
        Y[n * p + i] = v[i];
    for (int64_t j = 0; j < p; j++)
        for (int64_t i = 0; i < p; i++)
            Y[(n + 1 + j) * p + i] = (i == j) ? 1.0 : 0.0;
    sp_trsm_lower(Lf, (int)p, Y, (int)(n + 1 + p));

    /* LiHPt = Y[:, :n].T (C n×p), w = Y[:, n], Li = Y[:, n+1:] (F p×p) */
    arr_t aLiHPt = mk2(Y, n, p, p, 1), aw = mk1(Y + n * p, p, 1);
    arr_t aLi = mk2(Y + (n + 1) * p, p, p, 1, p);

    /* K = LiHPt.dot(Li); xn = x + LiHPt.dot(w); xn[ipsi] = wrap_2pi(xn[ipsi]) */
    if (np_dot(&aLiHPt, &aLi, K, n * p) || np_dot(&aLiHPt, &aw, t, n))
        goto fallback;
    for (int64_t i = 0; i < n; i++)
        xn[i] = x[i] + t[i];
    xn[ipsi] = rem_2pi(xn[ipsi]);

    /* Pn: (I - KH) P (I - KH)ᵀ + K R Kᵀ, or P - K HP; then (Pn + Pnᵀ)·0.5 */
    arr_t aK = mk2(K, n, p, p, 1);
    if (joseph) {
        arr_t aA = mk2(A, n, n, n, 1), aAP = mk2(AP, n, n, n, 1), aAt = mk2(A, n, n, 1, n);
        arr_t aR = mk2(R, p, p, p, 1), aKR = mk2(KR, n, p, p, 1), aKt = mk2(K, p, n, 1, p);
        if (np_dot(&aK, &aH, KH, n * n))
            goto fallback;
        /* A = I - KH: 0.0 - KH off the diagonal, 1.0 - KH on it (the same subtractions) */
        for (int64_t i = 0; i < n * n; i++)
            A[i] = 0.0 - KH[i];
        for (int64_t i = 0; i < n; i++)
            A[i * n + i] = 1.0 - KH[i * n + i];
        if (np_dot(&aA, &aP, AP, n * n) || np_dot(&aAP, &aAt, Pj, n * n) ||
            np_dot(&aK, &aR, KR, n * p) || np_dot(&aKR, &aKt, KRKt, n * n))
            goto fallback;
        for (int64_t i = 0; i < n * n; i++)
            Pj[i] = Pj[i] + KRKt[i];
    }
    else {
        if (np_dot(&aK, &aHP, KH, n * n))
            goto fallback;
        for (int64_t i = 0; i < n * n; i++)
            Pj[i] = P[i] - KH[i];
    }
    /* (Pj + Pjᵀ) then · 0.5, each rounded (no contraction): one pass */
    for (int64_t i = 0; i < n; i++)
        for (int64_t j = 0; j < n; j++)
            Pn[i * n + j] = (Pj[i * n + j] + Pj[j * n + i]) * 0.5;

    /* nis = float(w.dot(w)); every variance > 0 and nis finite, else the Python raises; a
     * variance within VARIANCE_FLOOR·κ of zero relative to its prior goes to the Python too */
    double nis;
    if (np_dot(&aw, &aw, &nis, 1))
        goto fallback;
    double tr_s = 0.0, tr_si = 0.0;
    for (int64_t i = 0; i < p; i++)
        tr_s += S[i * p + i];
    for (int64_t i = 0; i < p * p; i++) /* ‖L⁻¹‖²_F of Li (Y's last p columns) */
        tr_si += Y[(n + 1) * p + i] * Y[(n + 1) * p + i];
    double floor_rel = VARIANCE_FLOOR * tr_s * tr_si;
    for (int64_t i = 0; i < n; i++)
        if (!(0.0 < Pn[i * n + i] && floor_rel * P[i * n + i] < Pn[i * n + i]))
            goto fallback;
    if (!isfinite(nis))
        goto fallback;
    *nis_out = nis;
    *t_ok_out = ls_t(Y + (n + 1) * p, Y + n * p, p, t_ls);
    status = 1;
    goto done;

fallback:
    status = 0;
done:
    if (work != stack_work)
        PyMem_Free(work);
    return status;
}

/* The flags and the (checked) inputs x, P, H, z, R of update() / update_new() (args[0..4];
 * args[ia], args[ia+1], args[ia+2] are angle_rows, joseph, ipsi): 1, 0 (the Python runs) or
 * -1 (exception set). With z_raw not NULL, z and R (p_raw rows: R p_raw×p_raw, C order) are
 * these C arrays instead of args[3] and args[4] (update_blocks' stacked rows). */
static int update_inputs_raw(bufs_t *bs, PyObject *const *args, int ia, const double *z_raw,
                             const double *R_raw, int64_t p_raw, const double **x,
                             const double **P, const double **H, const double **z,
                             const double **R, int64_t *p, int64_t *n, int *joseph,
                             Py_ssize_t *ipsi)
{
    if (!bound) {
        PyErr_SetString(PyExc_RuntimeError, "kalman_update: _bind(addresses) first");
        return -1;
    }
    if ((*joseph = PyObject_IsTrue(args[ia + 1])) < 0)
        return -1;
    *ipsi = PyNumber_AsSsize_t(args[ia + 2], PyExc_OverflowError);
    if (*ipsi == -1 && PyErr_Occurred())
        return -1;
    Py_buffer *hv = &bs->v[0];
    if (!(*H = get(bs, args[2], 2, -1, -1, 0)))
        return 0;
    *p = hv->shape[0];
    *n = hv->shape[1];
    if (*p < 1 || *n < 2 || *p > 1000000 || *ipsi < 0 || *ipsi >= *n)
        return 0;
    if (!(*x = get(bs, args[0], 1, *n, 0, 0)) || !(*P = get(bs, args[1], 2, *n, *n, 0)))
        return 0;
    if (z_raw != NULL) {
        if (*p != p_raw)
            return 0;
        *z = z_raw;
        *R = R_raw;
        return 1;
    }
    if (!(*z = get(bs, args[3], 1, *p, 0, 0)) || !(*R = get(bs, args[4], 2, *p, *p, 0)))
        return 0;
    return 1;
}

/* update_inputs_raw() of args[3] and args[4]. */
static int update_inputs(bufs_t *bs, PyObject *const *args, int ia, const double **x,
                         const double **P, const double **H, const double **z, const double **R,
                         int64_t *p, int64_t *n, int *joseph, Py_ssize_t *ipsi)
{
    return update_inputs_raw(bs, args, ia, NULL, NULL, 0, x, P, H, z, R, p, n, joseph, ipsi);
}

PyDoc_STRVAR(update_doc,
"update(x, P, H, z, R, Y, v, S, K, xn, Pn, t, angle_rows, joseph, ipsi) -> (nis, t_ok) | None\n\n"
"The numeric core of engine.filter.update._update_py into the given C-contiguous arrays:\n"
"v (p,), S (p,p), Y ((n+1+p)×p: Y.T is L⁻¹[HP | v | I]), K (n,p), xn (n,), Pn (n,n) and the\n"
"LS statistics t (p,). Returns the NIS wᵀw and whether t was filled (not for p ≥ 8 or a\n"
"non-finite step), or None (the caller then runs the Python).");

static PyObject *py_update(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    bufs_t bs = {.n = 0};
    PyObject *result = NULL;
    if (nargs != 15) {
        PyErr_SetString(PyExc_TypeError, "update takes 15 arguments");
        return NULL;
    }
    const double *H, *x, *P, *z, *R;
    double *Y, *v, *S, *K, *xn, *Pn, *t_ls;
    int64_t p, n;
    int joseph, st;
    Py_ssize_t ipsi;
    if ((st = update_inputs(&bs, args, 12, &x, &P, &H, &z, &R, &p, &n, &joseph, &ipsi)) < 0)
        goto done;
    if (st == 0)
        goto fallback;
    if (!(Y = get(&bs, args[5], 2, n + 1 + p, p, 1)) || !(v = get(&bs, args[6], 1, p, 0, 1)) ||
        !(S = get(&bs, args[7], 2, p, p, 1)) || !(K = get(&bs, args[8], 2, n, p, 1)) ||
        !(xn = get(&bs, args[9], 1, n, 0, 1)) || !(Pn = get(&bs, args[10], 2, n, n, 1)) ||
        !(t_ls = get(&bs, args[11], 1, p, 0, 1)))
        goto fallback;
    double nis;
    int t_ok;
    st = update_core(x, P, H, z, R, p, n, args[12], joseph, ipsi, Y, v, S, K, xn, Pn, t_ls, &nis,
                     &t_ok);
    if (st < 0)
        goto done;
    if (st == 0)
        goto fallback;
    result = Py_BuildValue("(dO)", nis, t_ok ? Py_True : Py_False);
    goto done;

fallback:
    result = Py_NewRef(Py_None);
done:
    release(&bs);
    return result;
}

PyDoc_STRVAR(update_new_doc,
"update_new(x, P, H, z, R, angle_rows, joseph, ipsi)\n"
"    -> (nis, t_ok, v, S, K, xn, Pn, t, Y) | None\n\n"
"update() with its outputs made here (new C-ordered numpy arrays, the shapes update() takes)\n"
"and returned; xn and Pn read-only, t too when t_ok (else t is unfilled). None: the caller\n"
"runs the Python.");

/* update_new()'s work: args as update_new() takes them (x, P, H, z, R, angle_rows, joseph,
 * ipsi; z and R unread when z_raw is not NULL, see update_inputs_raw()). Fills o[0..6] with the
 * new arrays Y, v, S, K, xn, Pn, t (references owned by the caller, NULL where not made), *nis
 * and *t_ok. Returns 1, 0 (the Python runs; arrays made are the caller's to drop) or -1
 * (exception set). */
static int update_make(PyObject *const *args, const double *z_raw, const double *R_raw,
                       int64_t p_raw, PyObject **o, double *nis, int *t_ok)
{
    bufs_t bs = {.n = 0};
    const double *H, *x, *P, *z, *R;
    double *d[7]; /* Y, v, S, K, xn, Pn, t */
    int64_t p, n;
    int joseph, st;
    Py_ssize_t ipsi;
    st = update_inputs_raw(&bs, args, 5, z_raw, R_raw, p_raw, &x, &P, &H, &z, &R, &p, &n, &joseph,
                           &ipsi);
    if (st <= 0)
        goto done;
    if (!(o[0] = new_array(n + 1 + p, p, 2, &d[0])) || !(o[1] = new_array(p, 0, 1, &d[1])) ||
        !(o[2] = new_array(p, p, 2, &d[2])) || !(o[3] = new_array(n, p, 2, &d[3])) ||
        !(o[4] = new_array(n, 0, 1, &d[4])) || !(o[5] = new_array(n, n, 2, &d[5])) ||
        !(o[6] = new_array(p, 0, 1, &d[6]))) {
        st = -1;
        goto done;
    }
    st = update_core(x, P, H, z, R, p, n, args[5], joseph, ipsi, d[0], d[1], d[2], d[3], d[4],
                     d[5], d[6], nis, t_ok);
    if (st <= 0)
        goto done;
    if (freeze(o[4]) < 0 || freeze(o[5]) < 0 || (*t_ok && freeze(o[6]) < 0))
        st = -1;
done:
    release(&bs);
    return st;
}

static PyObject *py_update_new(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    PyObject *result = NULL, *o[7] = {NULL};
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "update_new takes 8 arguments");
        return NULL;
    }
    if (np_ready() < 0)
        return NULL;
    double nis;
    int t_ok, st = update_make(args, NULL, NULL, 0, o, &nis, &t_ok);
    if (st < 0)
        goto done;
    if (st == 0)
        goto fallback;
    /* (nis, t_ok, v, S, K, xn, Pn, t, Y): the tuple takes the arrays' references */
    PyObject *fnis = PyFloat_FromDouble(nis);
    if (fnis == NULL || (result = PyTuple_New(9)) == NULL) {
        Py_XDECREF(fnis);
        goto done;
    }
    PyTuple_SET_ITEM(result, 0, fnis);
    PyTuple_SET_ITEM(result, 1, Py_NewRef(t_ok ? Py_True : Py_False));
    for (int i = 1; i < 7; i++) {
        PyTuple_SET_ITEM(result, i + 1, o[i]);
        o[i] = NULL;
    }
    PyTuple_SET_ITEM(result, 8, o[0]);
    o[0] = NULL;
    goto done;

fallback:
    result = Py_NewRef(Py_None);
done:
    for (int i = 0; i < 7; i++)
        Py_XDECREF(o[i]);
    return result;
}

/* ------------------------------------------------------------------ the whole UpdateResult */

/* update_result(): engine.filter.update.update's steps after its rows are full width, in one
 * call: update_new()'s arrays, then the objects the Python builds from them, in its order and
 * with the same values — the new FilterState (the input state's instance dict, then x⁺ and P⁺,
 * as FilterState._with_frozen fills it), the LomTest (_lom_from_nis: T = nis / p against the
 * bounds of _lom_limits(p, α), remembered here per (p, α) as the Python's _LIMITS remembers
 * them), the LsTest (l_inv = Y[:, n+1:] and w = Y[:, n] of Y = Yc.T, numpy's own views; t set
 * when the kernel filled it) and the UpdateResult, each a bare instance whose attributes are
 * set as object.__setattr__ sets them. Bound once by bind_result(). */
static PyObject *r_state_cls = NULL, *r_lom_cls = NULL, *r_ls_cls = NULL, *r_result_cls = NULL;
static PyObject *r_limits = NULL, *r_empty = NULL, *r_key_w_slice = NULL;
static PyObject *rs_x, *rs_P, *rs_T, *rs_t, *rs_lower, *rs_upper, *rs_dof, *rs_verdict, *rs_l_inv,
    *rs_w, *rs_lom_reject, *rs_state, *rs_innovation, *rs_S, *rs_K, *rs_labels, *rs_lom, *rs_ls,
    *rs_fix_cov;
static PyObject *rv_reject, *rv_too_small, *rv_accept;

#define NLIM 32
typedef struct {
    Py_ssize_t p;
    double alpha;
    PyObject *lo, *hi; /* the floats _lom_limits returned (references held) */
} lim_t;
static lim_t lims[NLIM];
static int nlims = 0;

static PyObject *ku_bind_result(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const char *names[19] = {"x", "P", "T", "t", "lower", "upper", "dof", "verdict",
                                    "l_inv", "w", "lom_reject", "state", "innovation", "S", "K",
                                    "labels", "lom", "ls", "fix_cov"};
    PyObject **slots[19] = {&rs_x, &rs_P, &rs_T, &rs_t, &rs_lower, &rs_upper, &rs_dof,
                            &rs_verdict, &rs_l_inv, &rs_w, &rs_lom_reject, &rs_state,
                            &rs_innovation, &rs_S, &rs_K, &rs_labels, &rs_lom, &rs_ls,
                            &rs_fix_cov};
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError,
                        "bind_result(FilterState, LomTest, LsTest, UpdateResult, lom_limits)");
        return NULL;
    }
    for (int i = 0; i < 4; i++)
        if (!PyType_Check(args[i])) {
            PyErr_SetString(PyExc_TypeError, "bind_result: the first four must be classes");
            return NULL;
        }
    for (int i = 0; i < 19; i++)
        if (*slots[i] == NULL && (*slots[i] = PyUnicode_InternFromString(names[i])) == NULL)
            return NULL;
    if ((rv_reject == NULL && (rv_reject = PyUnicode_InternFromString("reject")) == NULL) ||
        (rv_too_small == NULL &&
         (rv_too_small = PyUnicode_InternFromString("too small")) == NULL) ||
        (rv_accept == NULL && (rv_accept = PyUnicode_InternFromString("accept")) == NULL) ||
        (r_empty == NULL && (r_empty = PyTuple_New(0)) == NULL))
        return NULL;
    Py_XSETREF(r_state_cls, Py_NewRef(args[0]));
    Py_XSETREF(r_lom_cls, Py_NewRef(args[1]));
    Py_XSETREF(r_ls_cls, Py_NewRef(args[2]));
    Py_XSETREF(r_result_cls, Py_NewRef(args[3]));
    Py_XSETREF(r_limits, Py_NewRef(args[4]));
    for (int i = 0; i < nlims; i++) {
        Py_CLEAR(lims[i].lo);
        Py_CLEAR(lims[i].hi);
    }
    nlims = 0;
    Py_RETURN_NONE;
}

/* The bounds (lower, upper) of the LOM test on p rows at α as _lom_limits(p, α) gives them
 * (borrowed), or -1 (exception set) / 0 (not two floats: the Python runs). */
static int lom_limits(Py_ssize_t p, double alpha, PyObject *alpha_obj, PyObject **lo,
                      PyObject **hi)
{
    for (int i = 0; i < nlims; i++)
        if (lims[i].p == p && lims[i].alpha == alpha) {
            *lo = lims[i].lo;
            *hi = lims[i].hi;
            return 1;
        }
    PyObject *pa[2] = {PyLong_FromSsize_t(p), alpha_obj};
    if (pa[0] == NULL)
        return -1;
    PyObject *r = PyObject_Vectorcall(r_limits, pa, 2, NULL);
    Py_DECREF(pa[0]);
    if (r == NULL)
        return -1;
    if (!PyTuple_CheckExact(r) || PyTuple_GET_SIZE(r) != 2 ||
        !PyFloat_CheckExact(PyTuple_GET_ITEM(r, 0)) ||
        !PyFloat_CheckExact(PyTuple_GET_ITEM(r, 1))) {
        Py_DECREF(r);
        return 0;
    }
    if (nlims == NLIM) {
        for (int i = 0; i < nlims; i++) {
            Py_CLEAR(lims[i].lo);
            Py_CLEAR(lims[i].hi);
        }
        nlims = 0;
    }
    lim_t *e = &lims[nlims++];
    e->p = p;
    e->alpha = alpha;
    e->lo = Py_NewRef(PyTuple_GET_ITEM(r, 0));
    e->hi = Py_NewRef(PyTuple_GET_ITEM(r, 1));
    Py_DECREF(r);
    *lo = e->lo;
    *hi = e->hi;
    return 1;
}

/* A bare instance of `cls` (object.__new__(cls)) with `n` attributes set as object.__setattr__
 * sets them, or NULL (exception set). */
static PyObject *bare_with(PyObject *cls, int n, PyObject *const *names, PyObject *const *vals)
{
    PyObject *obj = PyBaseObject_Type.tp_new((PyTypeObject *)cls, r_empty, NULL);
    if (obj == NULL)
        return NULL;
    for (int i = 0; i < n; i++)
        if (PyObject_GenericSetAttr(obj, names[i], vals[i]) < 0) {
            Py_DECREF(obj);
            return NULL;
        }
    return obj;
}

PyDoc_STRVAR(update_result_doc,
"update_result(state, H, z, R, angle_rows, joseph, ipsi, alpha, labels[, fix_cov])\n"
"    -> UpdateResult | None\n\n"
"engine.filter.update.update for rows already full width (H over all of state's columns): the\n"
"update_new() arrays and the result objects built from them as the Python builds them; a\n"
"fix_cov (not None) is the new state's (the update of state.with_fix_cov(keys, C) whose\n"
"sym2(C) it is, without that intermediate state). None (nothing made) where update_new()\n"
"declines or α is not a finite float: the Python runs.");

/* l_inv = Y[:, n + 1:] and w = Y[:, n] of Y = Yc.T (Yc C-ordered (n+1+p)×p) as numpy makes these
 * views: made here from Yc's data (PyArray_NewFromDescr with the views' shapes and strides, the
 * writeable flag of a view of a writeable array, base Yc: the array that owns the data, where
 * numpy's view of a view points too) once views_probe() found them equal to numpy's own in
 * shape, strides, flags and base; else (or views_probe() failing) by numpy's .T and indexing.
 * 1, or -1 (exception set). */
static int views_state = -1; /* 1: made here, 0: numpy's indexing, -1: not probed yet */

static PyObject *view_here(PyObject *Yc, int nd, Py_ssize_t d0, Py_ssize_t d1, Py_ssize_t s0,
                           Py_ssize_t s1, double *data)
{
    Py_ssize_t dims[2] = {d0, d1}, strides[2] = {s0, s1};
    Py_INCREF(np_f64); /* stolen */
    PyObject *a = np_new_from_descr((PyTypeObject *)np_ndarray, np_f64, nd, dims, strides, data,
                                    NP_WRITEABLE, NULL);
    if (a == NULL)
        return NULL;
    PyArray_SetBaseObject((PyArrayObject *)a, Py_NewRef(Yc));
    return a;
}

static int views_numpy(PyObject *Yc, Py_ssize_t n, PyObject **l_inv, PyObject **w)
{
    PyObject *Y = NULL, *nidx = NULL, *sl = NULL, *key = NULL;
    int st = -1;
    *l_inv = *w = NULL;
    if (r_key_w_slice == NULL && (r_key_w_slice = PySlice_New(NULL, NULL, NULL)) == NULL)
        return -1;
    if ((Y = PyObject_GetAttr(Yc, rs_T)) == NULL)
        goto done;
    if ((nidx = PyLong_FromSsize_t(n + 1)) == NULL || (sl = PySlice_New(nidx, NULL, NULL)) == NULL ||
        (key = PyTuple_Pack(2, r_key_w_slice, sl)) == NULL ||
        (*l_inv = PyObject_GetItem(Y, key)) == NULL)
        goto done;
    Py_CLEAR(key);
    Py_CLEAR(nidx);
    if ((nidx = PyLong_FromSsize_t(n)) == NULL ||
        (key = PyTuple_Pack(2, r_key_w_slice, nidx)) == NULL || (*w = PyObject_GetItem(Y, key)) == NULL)
        goto done;
    st = 1;
done:
    if (st < 0) {
        Py_CLEAR(*l_inv);
        Py_CLEAR(*w);
    }
    Py_XDECREF(Y);
    Py_XDECREF(nidx);
    Py_XDECREF(sl);
    Py_XDECREF(key);
    return st;
}

static int views_made(PyObject *Yc, Py_ssize_t n, Py_ssize_t p, PyObject **l_inv, PyObject **w)
{
    double *d = (double *)PyArray_BYTES(((np_fields_t *)Yc));
    *w = NULL;
    if ((*l_inv = view_here(Yc, 2, p, p, 8, 8 * p, d + (n + 1) * p)) == NULL ||
        (*w = view_here(Yc, 1, p, 0, 8, 0, d + n * p)) == NULL) {
        Py_CLEAR(*l_inv);
        return -1;
    }
    return 1;
}

/* Are views_made()'s arrays numpy's (views_numpy()) on probe arrays of the shapes the filter
 * uses (p = 1, 2, 5)? Sets views_state; 0, or -1 (exception set). */
static int views_probe(void)
{
    int ok = np_layout == 1;
    for (Py_ssize_t p = 1; ok && p <= 5; p += (p == 2 ? 3 : 1)) {
        Py_ssize_t n = 13;
        double *d;
        PyObject *Yc = new_array(n + 1 + p, p, 2, &d), *a[2] = {NULL}, *b[2] = {NULL};
        if (Yc == NULL)
            return -1;
        if (views_numpy(Yc, n, &a[0], &a[1]) < 0 || views_made(Yc, n, p, &b[0], &b[1]) < 0) {
            Py_XDECREF(a[0]);
            Py_XDECREF(a[1]);
            Py_DECREF(Yc);
            return -1;
        }
        for (int i = 0; i < 2 && ok; i++) {
            np_fields_t *fa = (np_fields_t *)a[i], *fb = (np_fields_t *)b[i];
            ok = Py_TYPE(a[i]) == Py_TYPE(b[i]) && PyArray_BYTES(fa) == PyArray_BYTES(fb) && PyArray_NDIM(fa) == PyArray_NDIM(fb) &&
                 PyArray_BASE(fa) == PyArray_BASE(fb) && PyArray_BASE(fa) == Yc && PyArray_DESCR(fa) == PyArray_DESCR(fb) &&
                 PyArray_FLAGS(fa) == PyArray_FLAGS(fb);
            for (int k = 0; k < PyArray_NDIM(fa) && ok; k++)
                ok = PyArray_DIMS(fa)[k] == PyArray_DIMS(fb)[k] && PyArray_STRIDES(fa)[k] == PyArray_STRIDES(fb)[k];
            if (ok) { /* and what Python sees: the flags object compares equal */
                PyObject *fla = PyObject_GetAttrString(a[i], "flags");
                PyObject *flb = fla == NULL ? NULL : PyObject_GetAttrString(b[i], "flags");
                int eq = flb == NULL ? -1 : PyObject_RichCompareBool(fla, flb, Py_EQ);
                Py_XDECREF(fla);
                Py_XDECREF(flb);
                if (eq < 0)
                    PyErr_Clear();
                ok = eq == 1;
            }
        }
        for (int i = 0; i < 2; i++) {
            Py_XDECREF(a[i]);
            Py_XDECREF(b[i]);
        }
        Py_DECREF(Yc);
    }
    views_state = ok;
    return 0;
}

static int ls_views(PyObject *Yc, Py_ssize_t n, Py_ssize_t p, PyObject **l_inv, PyObject **w)
{
    if (views_state < 0 && views_probe() < 0)
        return -1;
    if (views_state == 1)
        return views_made(Yc, n, p, l_inv, w);
    return views_numpy(Yc, n, l_inv, w);
}

/* update_result() of args (state, H, z, R, angle_rows, joseph, ipsi, alpha, labels[, fix_cov];
 * z and R unread when z_raw is not NULL: update_inputs_raw()). */
static PyObject *result_build(PyObject *const *args, Py_ssize_t nargs, const double *z_raw,
                              const double *R_raw, int64_t p_raw)
{
    if (r_result_cls == NULL) {
        PyErr_SetString(PyExc_RuntimeError, "kalman_update: bind_result(...) first");
        return NULL;
    }
    PyObject *state = args[0], *alpha_obj = args[7];
    if (!PyFloat_CheckExact(alpha_obj) || !isfinite(PyFloat_AS_DOUBLE(alpha_obj)))
        Py_RETURN_NONE;
    if (np_ready() < 0)
        return NULL;
    PyObject *result = NULL, *xo = NULL, *Po = NULL, *o[7] = {NULL};
    PyObject *l_inv = NULL, *w = NULL, *newst = NULL, *src = NULL, *dst = NULL, *lom = NULL;
    PyObject *ls = NULL, *tval = NULL, *dof = NULL;
    PyObject *lo = NULL, *hi = NULL;
    if ((xo = PyObject_GetAttr(state, rs_x)) == NULL || (Po = PyObject_GetAttr(state, rs_P)) == NULL)
        goto done;
    PyObject *ua[8] = {xo, Po, args[1], args[2], args[3], args[4], args[5], args[6]};
    double nis;
    int t_ok;
    int st = update_make(ua, z_raw, R_raw, p_raw, o, &nis, &t_ok);
    if (st < 0)
        goto done;
    if (st == 0) {
        result = Py_NewRef(Py_None);
        goto done;
    }
    /* Y, v, S, K, xn, Pn, t */
    PyObject *Yc = o[0], *v = o[1], *S = o[2], *K = o[3], *xn = o[4], *Pn = o[5], *t = o[6];
    Py_ssize_t p = PyArray_DIMS(((np_fields_t *)v))[0], n = PyArray_DIMS(((np_fields_t *)xn))[0];
    if (np_layout != 1) {
        p = PyObject_Length(v);
        n = PyObject_Length(xn);
        if (p < 0 || n < 0)
            goto done;
    }
    st = lom_limits(p, PyFloat_AS_DOUBLE(alpha_obj), alpha_obj, &lo, &hi);
    if (st < 0) {
        lo = hi = NULL;
        goto done;
    }
    if (st == 0) {
        lo = hi = NULL;
        result = Py_NewRef(Py_None);
        goto done;
    }
    /* own references: the table may be refilled (another thread) while objects are made */
    Py_INCREF(lo);
    Py_INCREF(hi);
    /* new = state._with_frozen(state.t, xn, Pn): its instance dict a copy of state's (the same
     * keys in the same order as the Python's update of an empty dict; a copy of a split-table
     * dict shares its keys instead of inserting them one by one), then fix_cov, x and P */
    if ((newst = PyBaseObject_Type.tp_new((PyTypeObject *)r_state_cls, r_empty, NULL)) == NULL ||
        (src = PyObject_GenericGetDict(state, NULL)) == NULL ||
        (dst = PyDict_Copy(src)) == NULL ||
        (nargs == 10 && args[9] != Py_None && PyDict_SetItem(dst, rs_fix_cov, args[9]) < 0) ||
        PyDict_SetItem(dst, rs_x, xn) < 0 || PyDict_SetItem(dst, rs_P, Pn) < 0 ||
        uvn_set_attrs(newst, dst) < 0)
        goto done;
    /* lom = _lom_from_nis(nis, p, alpha) */
    double tv = nis / (double)p;
    double upper = PyFloat_AS_DOUBLE(hi), lower = PyFloat_AS_DOUBLE(lo);
    PyObject *verdict = tv > upper ? rv_reject : (tv < lower ? rv_too_small : rv_accept);
    if ((tval = PyFloat_FromDouble(tv)) == NULL || (dof = PyLong_FromSsize_t(p)) == NULL)
        goto done;
    {
        PyObject *names[5] = {rs_t, rs_lower, rs_upper, rs_dof, rs_verdict};
        PyObject *vals[5] = {tval, lo, hi, dof, verdict};
        if ((lom = bare_with(r_lom_cls, 5, names, vals)) == NULL)
            goto done;
    }
    /* Y = Yc.T; l_inv = Y[:, n + 1:]; w = Y[:, n] (numpy's views) */
    if (ls_views(Yc, n, p, &l_inv, &w) < 0)
        goto done;
    {
        PyObject *names[4] = {rs_l_inv, rs_w, rs_lom_reject, rs_t};
        PyObject *vals[4] = {l_inv, w, verdict == rv_reject ? Py_True : Py_False, t};
        if ((ls = bare_with(r_ls_cls, t_ok ? 4 : 3, names, vals)) == NULL)
            goto done;
    }
    {
        PyObject *names[7] = {rs_state, rs_innovation, rs_S, rs_K, rs_labels, rs_lom, rs_ls};
        PyObject *vals[7] = {newst, v, S, K, args[8], lom, ls};
        result = bare_with(r_result_cls, 7, names, vals);
    }
done:
    for (int i = 0; i < 7; i++)
        Py_XDECREF(o[i]);
    Py_XDECREF(xo);
    Py_XDECREF(Po);
    Py_XDECREF(l_inv);
    Py_XDECREF(w);
    Py_XDECREF(newst);
    Py_XDECREF(src);
    Py_XDECREF(dst);
    Py_XDECREF(lom);
    Py_XDECREF(ls);
    Py_XDECREF(tval);
    Py_XDECREF(dof);
    Py_XDECREF(lo);
    Py_XDECREF(hi);
    return result;
}

static PyObject *py_update_result(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 9 && nargs != 10) {
        PyErr_SetString(PyExc_TypeError, "update_result takes 9 or 10 arguments");
        return NULL;
    }
    return result_build(args, nargs, NULL, NULL, 0);
}

/* One block of update_blocks(): its rows' values into z (k of them) and their VCV into the k×k
 * block at R (row stride ld). A list of floats is the values, or the variances of independent
 * rows (R diagonal); an array is read as a C-contiguous float64 (k,) / (k, k). Returns k, or -1
 * (not covered: the Python runs; no exception left set). With z == NULL only counts. */
static Py_ssize_t block_rows(PyObject *zo, PyObject *Ro, double *z, double *R, Py_ssize_t ld)
{
    Py_ssize_t k;
    if (PyList_CheckExact(zo)) {
        k = PyList_GET_SIZE(zo);
        for (Py_ssize_t i = 0; i < k; i++)
            if (!PyFloat_CheckExact(PyList_GET_ITEM(zo, i)))
                return -1;
        if (z != NULL)
            for (Py_ssize_t i = 0; i < k; i++)
                z[i] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(zo, i));
    } else {
        bufs_t bs = {.n = 0};
        const double *d = get(&bs, zo, 1, -1, 0, 0);
        k = d == NULL ? -1 : bs.v[0].shape[0];
        if (d != NULL && z != NULL)
            memcpy(z, d, sizeof(double) * (size_t)k);
        release(&bs);
        if (k < 0)
            return -1;
    }
    if (PyList_CheckExact(Ro)) {
        if (PyList_GET_SIZE(Ro) != k)
            return -1;
        for (Py_ssize_t i = 0; i < k; i++)
            if (!PyFloat_CheckExact(PyList_GET_ITEM(Ro, i)))
                return -1;
        if (R != NULL)
            for (Py_ssize_t i = 0; i < k; i++)
                R[i * ld + i] = PyFloat_AS_DOUBLE(PyList_GET_ITEM(Ro, i));
    } else {
        bufs_t bs = {.n = 0};
        const double *d = get(&bs, Ro, 2, k, k, 0);
        if (d != NULL && R != NULL)
            for (Py_ssize_t i = 0; i < k; i++)
                memcpy(R + i * ld, d + i * k, sizeof(double) * (size_t)k);
        release(&bs);
        if (d == NULL)
            return -1;
    }
    return k;
}

PyDoc_STRVAR(update_blocks_doc,
"update_blocks(state, H, blocks, angle_rows, joseph, ipsi, alpha, labels[, fix_cov[, gate]])\n"
"    -> UpdateResult | (UpdateResult, float | None) | None\n\n"
"update_result() of the rows of `blocks`, a tuple of (z, R) stacked in order as\n"
"measurements.stack_measurements stacks them (z concatenated, R block-diagonal, zeros\n"
"elsewhere): z a list of floats or a float64 (k,) array, R a list of the rows' variances\n"
"(independent rows) or a float64 (k, k) array. None where a block is not one of these or\n"
"update_result() declines: the Python runs. With gate (an int, not None) the result comes\n"
"with distance(result.innovation, result.S, gate, p) of its rows gate: (the Mahalanobis\n"
"length of the last block for the cycle's gross-error gate; None where distance() declines).");

static PyObject *py_distance(PyObject *self, PyObject *const *args, Py_ssize_t nargs);


static PyObject *py_update_blocks(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < 8 || nargs > 10) {
        PyErr_SetString(PyExc_TypeError, "update_blocks takes 8 to 10 arguments");
        return NULL;
    }
    if (np_ready() < 0)
        return NULL;
    PyObject *blocks = args[2];
    if (!PyTuple_CheckExact(blocks))
        Py_RETURN_NONE;
    Py_ssize_t nb = PyTuple_GET_SIZE(blocks), p = 0;
    for (Py_ssize_t b = 0; b < nb; b++) {
        PyObject *blk = PyTuple_GET_ITEM(blocks, b);
        if (!PyTuple_CheckExact(blk) || PyTuple_GET_SIZE(blk) != 2)
            Py_RETURN_NONE;
        Py_ssize_t k = block_rows(PyTuple_GET_ITEM(blk, 0), PyTuple_GET_ITEM(blk, 1), NULL, NULL,
                                  0);
        if (k < 0)
            Py_RETURN_NONE;
        p += k;
    }
    if (p < 1 || p > 1000)
        Py_RETURN_NONE;
    /* the stacked z and R in C scratch (on the stack for up to 16 rows): update_core reads
     * them as it would read the arrays of these values */
    double zr_stack[16 + 16 * 16];
    double *zr = p <= 16 ? zr_stack : PyMem_Malloc(sizeof(double) * (size_t)(p + p * p));
    if (zr == NULL)
        return PyErr_NoMemory();
    double *z = zr, *R = zr + p;
    memset(R, 0, sizeof(double) * (size_t)(p * p));
    Py_ssize_t at = 0;
    for (Py_ssize_t b = 0; b < nb; b++) {
        PyObject *blk = PyTuple_GET_ITEM(blocks, b);
        at += block_rows(PyTuple_GET_ITEM(blk, 0), PyTuple_GET_ITEM(blk, 1), z + at,
                         R + at * p + at, p);
    }
    PyObject *ua[10] = {args[0], args[1], Py_None, Py_None, args[3], args[4], args[5], args[6],
                        args[7], nargs >= 9 ? args[8] : Py_None};
    PyObject *result = result_build(ua, 10, z, R, p);
    if (zr != zr_stack)
        PyMem_Free(zr);
    if (result == NULL || result == Py_None || nargs < 10 || args[9] == Py_None)
        return result;
    /* (result, innovation_distance(result, slice(gate, None))) */
    PyObject *v = PyObject_GetAttr(result, rs_innovation);
    PyObject *S = v == NULL ? NULL : PyObject_GetAttr(result, rs_S);
    PyObject *stop = S == NULL ? NULL : PyLong_FromSsize_t(p);
    PyObject *d = NULL, *pair = NULL;
    if (stop != NULL) {
        PyObject *da[4] = {v, S, args[9], stop};
        d = py_distance(self, da, 4);
    }
    if (d != NULL)
        pair = PyTuple_Pack(2, result, d);
    Py_XDECREF(v);
    Py_XDECREF(S);
    Py_XDECREF(stop);
    Py_XDECREF(d);
    Py_DECREF(result);
    return pair;
}

/* ------------------------------------------------------------------ innovation distance */

PyDoc_STRVAR(distance_doc,
"distance(innovation, S, start, stop) -> float | None\n\n"
"√(v̂ᵀS⁻¹v̂) of rows start:stop (engine.filter.update.innovation_distance); None if the\n"
"arrays are not C-contiguous float64 or that block of S is not positive definite or near\n"
"singular (its factor borderline: the reference decides, inf where it does not factorise).");

static PyObject *py_distance(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    bufs_t bs = {.n = 0};
    PyObject *result = NULL;
    double *work = NULL;
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "distance takes 4 arguments");
        return NULL;
    }
    if (!bound) {
        PyErr_SetString(PyExc_RuntimeError, "kalman_update: _bind(addresses) first");
        return NULL;
    }
    Py_ssize_t start = PyNumber_AsSsize_t(args[2], PyExc_OverflowError);
    if (start == -1 && PyErr_Occurred())
        return NULL;
    Py_ssize_t stop = PyNumber_AsSsize_t(args[3], PyExc_OverflowError);
    if (stop == -1 && PyErr_Occurred())
        return NULL;
    const double *v, *S;
    if (!(v = get(&bs, args[0], 1, -1, 0, 0)))
        goto fallback;
    int64_t p = bs.v[0].shape[0];
    if (!(S = get(&bs, args[1], 2, p, p, 0)))
        goto fallback;
    if (start < 0 || stop > p || p > 1000000)
        goto fallback;
    if (stop <= start) {
        result = PyFloat_FromDouble(0.0);
        goto done;
    }
    int m = (int)(stop - start);
    work = PyMem_Malloc(sizeof(double) * (size_t)(m * m + m));
    if (work == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *Lf = work, *b = work + m * m;
    /* not positive definite (the reference's inf) or borderline: the reference decides */
    if (sp_potrf_lower(S + start * p + start, p, m, Lf) != 0 ||
        factor_borderline(S + start * p + start, p, m, Lf))
        goto fallback;
    memcpy(b, v + start, sizeof(double) * (size_t)m);
    sp_trsm_lower(Lf, m, b, 1);
    /* float(w @ w): matmul of two vectors is DOUBLE_dot, 0.0 + ddot, for any length */
    double d2 = np_vdot(m, b, 1, b, 1);
    result = PyFloat_FromDouble(d2 >= 0.0 ? sqrt(d2) : Py_HUGE_VAL);
    goto done;

fallback:
    result = Py_NewRef(Py_None);
done:
    PyMem_Free(work);
    release(&bs);
    return result;
}

/* ------------------------------------------------------------------ module */

static PyObject *py_bind(PyObject *self, PyObject *addresses)
{
    (void)addresses; /* the routines are this kernel's own (uvn_linalg.h): nothing to bind */
    Py_RETURN_NONE;
}

static PyObject *py_views_state(PyObject *self, PyObject *unused)
{
    return PyLong_FromLong(views_state);
}

static PyMethodDef methods[] = {
    UVN_PROBE_METHOD,
    {"_views_state", py_views_state, METH_NOARGS,
     "_views_state() -> 1 (the LsTest views made by the kernel), 0 (by numpy's indexing) or -1 "
     "(not probed yet)."},
    {"update", (PyCFunction)(void (*)(void))py_update, METH_FASTCALL, update_doc},
    {"update_new", (PyCFunction)(void (*)(void))py_update_new, METH_FASTCALL, update_new_doc},
    {"distance", (PyCFunction)(void (*)(void))py_distance, METH_FASTCALL, distance_doc},
    {"update_result", (PyCFunction)(void (*)(void))py_update_result, METH_FASTCALL,
     update_result_doc},
    {"update_blocks", (PyCFunction)(void (*)(void))py_update_blocks, METH_FASTCALL,
     update_blocks_doc},
    {"bind_result", (PyCFunction)(void (*)(void))ku_bind_result, METH_FASTCALL,
     "bind_result(FilterState, LomTest, LsTest, UpdateResult, lom_limits): what update_result() "
     "builds and the bounds it asks for."},
    {"_bind", py_bind, METH_O,
     "_bind(ignored): kept for callers; the small-matrix routines are the kernel's own."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "engine.native.kalman_update",
    "The filter's measurement update, compiled (engine/filter/update.py's numeric core).", -1,
    methods,
};

PyMODINIT_FUNC PyInit_kalman_update(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
