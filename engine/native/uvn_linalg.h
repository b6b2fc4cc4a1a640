/* Small dense linear algebra for the kernels' matrices (the filter's 11–32 states, the fix's
 * 2-unknown normal equations, the Decca 2×2 VCVs): the few BLAS/LAPACK operations they need,
 * written out here, so no BLAS library is looked up or linked.
 *
 * The signatures follow the reference BLAS/LAPACK (CBLAS order/transpose enums, Fortran-style
 * pointer arguments for the LAPACK routines) so the kernels read as the maths of the Python
 * they replace (numpy's ndarray.dot, scipy.linalg's dpotrf/dtrsm, numpy.linalg.inv). The
 * algorithms are the textbook ones (Golub & Van Loan, Matrix Computations, 4th ed.: inner
 * products 1.1, Cholesky 4.2.1, forward substitution 3.1.1, LU with partial pivoting 3.4).
 * Results agree with an optimised BLAS to rounding (a different summation order), which is what
 * the engine's tolerance contract asks (docs/PERFORMANCE.md), not bit for bit.
 */
#ifndef UVN_LINALG_H
#define UVN_LINALG_H

#include <math.h>
#include <stdint.h>

enum { UvnRowMajor = 101, UvnColMajor = 102 };
enum { UvnNoTrans = 111, UvnTrans = 112 };
enum { UvnUpper = 121, UvnLower = 122 };

/* C = alpha op(A) op(B) + beta C; op(A) is m×k, op(B) k×n; row- or column-major. */
static void uvn_dgemm(int order, int ta, int tb, int64_t m, int64_t n, int64_t k, double alpha,
                      const double *a, int64_t lda, const double *b, int64_t ldb, double beta,
                      double *c, int64_t ldc)
{
    if (order == UvnColMajor) { /* Cᵀ = op(B)ᵀ op(A)ᵀ in row-major */
        uvn_dgemm(UvnRowMajor, tb, ta, n, m, k, alpha, b, ldb, a, lda, beta, c, ldc);
        return;
    }
    const int64_t ai = ta == UvnNoTrans ? lda : 1, ap = ta == UvnNoTrans ? 1 : lda;
    const int64_t bp = tb == UvnNoTrans ? ldb : 1, bj = tb == UvnNoTrans ? 1 : ldb;
    for (int64_t i = 0; i < m; i++)
        for (int64_t j = 0; j < n; j++) {
            double s = 0.0;
            for (int64_t p = 0; p < k; p++)
                s += a[i * ai + p * ap] * b[p * bp + j * bj];
            double *cij = c + i * ldc + j;
            *cij = beta == 0.0 ? alpha * s : alpha * s + beta * *cij;
        }
}

/* y = alpha op(A) x + beta y; A is m×n. */
static void uvn_dgemv(int order, int trans, int64_t m, int64_t n, double alpha, const double *a,
                      int64_t lda, const double *x, int64_t incx, double beta, double *y,
                      int64_t incy)
{
    /* element (i, j) of A at a[i*ri + j*rj] */
    const int64_t ri = order == UvnRowMajor ? lda : 1, rj = order == UvnRowMajor ? 1 : lda;
    const int64_t rows = trans == UvnNoTrans ? m : n, cols = trans == UvnNoTrans ? n : m;
    for (int64_t i = 0; i < rows; i++) {
        double s = 0.0;
        for (int64_t j = 0; j < cols; j++) {
            double aij = trans == UvnNoTrans ? a[i * ri + j * rj] : a[j * ri + i * rj];
            s += aij * x[j * incx];
        }
        double *yi = y + i * incy;
        *yi = beta == 0.0 ? alpha * s : alpha * s + beta * *yi;
    }
}

static double uvn_ddot(int64_t n, const double *x, int64_t incx, const double *y, int64_t incy)
{
    double s = 0.0;
    for (int64_t i = 0; i < n; i++)
        s += x[i * incx] * y[i * incy];
    return s;
}

static void uvn_daxpy(int64_t n, double alpha, const double *x, int64_t incx, double *y,
                      int64_t incy)
{
    for (int64_t i = 0; i < n; i++)
        y[i * incy] += alpha * x[i * incx];
}

/* C = alpha op(A) op(A)ᵀ + beta C, op(A) n×k (NoTrans: A, Trans: Aᵀ). Both triangles are
 * written (a symmetric result), whatever uplo asks. */
static void uvn_dsyrk(int order, int uplo, int trans, int64_t n, int64_t k, double alpha,
                      const double *a, int64_t lda, double beta, double *c, int64_t ldc)
{
    (void)uplo;
    int rowmajor_notrans = (order == UvnRowMajor) == (trans == UvnNoTrans);
    /* element (i, p) of op(A) */
    const int64_t ri = rowmajor_notrans ? lda : 1, rp = rowmajor_notrans ? 1 : lda;
    for (int64_t i = 0; i < n; i++)
        for (int64_t j = 0; j <= i; j++) {
            double s = 0.0;
            for (int64_t p = 0; p < k; p++)
                s += a[i * ri + p * rp] * a[j * ri + p * rp];
            double *cij = c + i * ldc + j, *cji = c + j * ldc + i;
            double v = beta == 0.0 ? alpha * s : alpha * s + beta * *cij;
            *cij = v;
            *cji = v;
        }
}

/* Cholesky A = L Lᵀ of the column-major n×n a (lower triangle read and overwritten; the upper
 * left alone, as LAPACK's dpotrf('L')). info = 0, or j > 0: the leading j×j minor is not
 * positive definite. */
static void uvn_dpotrf(const char *uplo, const int *n, double *a, const int *lda, int *info)
{
    (void)uplo; /* 'L' only */
    const int N = *n, ld = *lda;
    *info = 0;
    for (int j = 0; j < N; j++) {
        double d = a[j + j * ld];
        for (int p = 0; p < j; p++)
            d -= a[j + p * ld] * a[j + p * ld];
        if (!(d > 0.0) || isnan(d)) {
            *info = j + 1;
            return;
        }
        d = sqrt(d);
        a[j + j * ld] = d;
        for (int i = j + 1; i < N; i++) {
            double s = a[i + j * ld];
            for (int p = 0; p < j; p++)
                s -= a[i + p * ld] * a[j + p * ld];
            a[i + j * ld] = s / d;
        }
    }
}

/* B ← alpha L⁻¹ B for the lower-triangular, non-unit column-major m×m L and column-major m×n B
 * (dtrsm with side 'L', uplo 'L', transa 'N', diag 'N': the only form the kernels use). */
static void uvn_dtrsm(const char *side, const char *uplo, const char *transa, const char *diag,
                      const int *m, const int *n, const double *alpha, const double *a,
                      const int *lda, double *b, const int *ldb)
{
    (void)side;
    (void)uplo;
    (void)transa;
    (void)diag;
    const int M = *m, N = *n, la = *lda, lb = *ldb;
    for (int j = 0; j < N; j++) {
        double *col = b + (int64_t)j * lb;
        if (*alpha != 1.0)
            for (int i = 0; i < M; i++)
                col[i] *= *alpha;
        for (int i = 0; i < M; i++) {
            double s = col[i];
            for (int p = 0; p < i; p++)
                s -= a[i + p * la] * col[p];
            col[i] = s / a[i + i * la];
        }
    }
}

/* Solve A X = B (column-major A n×n, B n×nrhs, overwritten by X; A by its LU factors) by LU
 * with partial pivoting (LAPACK's dgesv). info = 0, or j > 0 when U(j, j) is exactly zero. */
static void uvn_dgesv(const int64_t *n, const int64_t *nrhs, double *a, const int64_t *lda,
                      int64_t *ipiv, double *b, const int64_t *ldb, int64_t *info)
{
    const int64_t N = *n, R = *nrhs, la = *lda, lb = *ldb;
    *info = 0;
    for (int64_t j = 0; j < N; j++) {
        int64_t piv = j;
        for (int64_t i = j + 1; i < N; i++)
            if (fabs(a[i + j * la]) > fabs(a[piv + j * la]))
                piv = i;
        ipiv[j] = piv + 1;
        if (a[piv + j * la] == 0.0) {
            *info = j + 1;
            return;
        }
        if (piv != j) {
            for (int64_t c = 0; c < N; c++) {
                double t = a[j + c * la];
                a[j + c * la] = a[piv + c * la];
                a[piv + c * la] = t;
            }
            for (int64_t c = 0; c < R; c++) {
                double t = b[j + c * lb];
                b[j + c * lb] = b[piv + c * lb];
                b[piv + c * lb] = t;
            }
        }
        for (int64_t i = j + 1; i < N; i++) {
            double l = a[i + j * la] / a[j + j * la];
            a[i + j * la] = l;
            for (int64_t c = j + 1; c < N; c++)
                a[i + c * la] -= l * a[j + c * la];
            for (int64_t c = 0; c < R; c++)
                b[i + c * lb] -= l * b[j + c * lb];
        }
    }
    for (int64_t c = 0; c < R; c++) /* back substitution U x = y */
        for (int64_t i = N - 1; i >= 0; i--) {
            double s = b[i + c * lb];
            for (int64_t p = i + 1; p < N; p++)
                s -= a[i + p * la] * b[p + c * lb];
            b[i + c * lb] = s / a[i + i * la];
        }
}

/* The routines as one table, under the names the kernels call them by (B.dgemm, …). */
typedef struct {
    void (*dgemm)(int, int, int, int64_t, int64_t, int64_t, double, const double *, int64_t,
                  const double *, int64_t, double, double *, int64_t);
    void (*dgemv)(int, int, int64_t, int64_t, double, const double *, int64_t, const double *,
                  int64_t, double, double *, int64_t);
    double (*ddot)(int64_t, const double *, int64_t, const double *, int64_t);
    void (*dsyrk)(int, int, int, int64_t, int64_t, double, const double *, int64_t, double,
                  double *, int64_t);
    void (*daxpy)(int64_t, double, const double *, int64_t, double *, int64_t);
    void (*npl_dgesv)(const int64_t *, const int64_t *, double *, const int64_t *, int64_t *,
                      double *, const int64_t *, int64_t *);
    void (*dpotrf)(const char *, const int *, double *, const int *, int *);
    void (*dtrsm)(const char *, const char *, const char *, const char *, const int *,
                  const int *, const double *, const double *, const int *, double *,
                  const int *);
} uvn_linalg_t;

#define UVN_LINALG {uvn_dgemm, uvn_dgemv, uvn_ddot, uvn_dsyrk, uvn_daxpy, uvn_dgesv, \
                    uvn_dpotrf, uvn_dtrsm}

#endif /* UVN_LINALG_H */
