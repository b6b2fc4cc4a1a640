/* The BLAS/LAPACK routines numpy and SciPy call, as function pointers for the kernels.
 *
 * numpy's bundled OpenBLAS is ILP64 (64-bit integers, CBLAS interface, always called by numpy
 * with CblasRowMajor); SciPy's is LP64 (32-bit integers, Fortran interface). The addresses come
 * from engine/native/blas.py (all_addresses) through a kernel's _bind(dict). Calling the same
 * routine with the same arguments as numpy/SciPy is what keeps the bits (docs/PERFORMANCE.md).
 */
#ifndef UVN_BLAS_H
#define UVN_BLAS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>

enum { UvnRowMajor = 101, UvnColMajor = 102 };
enum { UvnNoTrans = 111, UvnTrans = 112 };
enum { UvnUpper = 121, UvnLower = 122 };

typedef void (*uvn_dgemm_t)(int order, int ta, int tb, int64_t m, int64_t n, int64_t k,
                            double alpha, const double *a, int64_t lda, const double *b,
                            int64_t ldb, double beta, double *c, int64_t ldc);
typedef void (*uvn_dgemv_t)(int order, int trans, int64_t m, int64_t n, double alpha,
                            const double *a, int64_t lda, const double *x, int64_t incx,
                            double beta, double *y, int64_t incy);
typedef double (*uvn_ddot_t)(int64_t n, const double *x, int64_t incx, const double *y,
                             int64_t incy);
typedef void (*uvn_dsyrk_t)(int order, int uplo, int trans, int64_t n, int64_t k, double alpha,
                            const double *a, int64_t lda, double beta, double *c, int64_t ldc);
typedef void (*uvn_daxpy_t)(int64_t n, double alpha, const double *x, int64_t incx, double *y,
                            int64_t incy);
/* numpy's own Fortran LAPACK (column-major, ILP64: every integer is 64-bit), numpy.linalg's. */
typedef void (*uvn_npl_dgesv_t)(const int64_t *n, const int64_t *nrhs, double *a,
                                const int64_t *lda, int64_t *ipiv, double *b,
                                const int64_t *ldb, int64_t *info);
typedef void (*uvn_npl_dgetrf_t)(const int64_t *m, const int64_t *n, double *a,
                                 const int64_t *lda, int64_t *ipiv, int64_t *info);
typedef void (*uvn_npl_dpotrf_t)(const char *uplo, const int64_t *n, double *a,
                                 const int64_t *lda, int64_t *info);
typedef void (*uvn_npl_dsyevd_t)(const char *jobz, const char *uplo, const int64_t *n,
                                 double *a, const int64_t *lda, double *w, double *work,
                                 const int64_t *lwork, int64_t *iwork, const int64_t *liwork,
                                 int64_t *info);
/* SciPy's Fortran LAPACK/BLAS (column-major, LP64). */
typedef void (*uvn_dpotrf_t)(const char *uplo, const int *n, double *a, const int *lda,
                             int *info);
typedef void (*uvn_dtrsm_t)(const char *side, const char *uplo, const char *transa,
                            const char *diag, const int *m, const int *n, const double *alpha,
                            const double *a, const int *lda, double *b, const int *ldb);
typedef void (*uvn_dgesv_t)(const int *n, const int *nrhs, double *a, const int *lda, int *ipiv,
                            double *b, const int *ldb, int *info);

typedef struct {
    uvn_dgemm_t dgemm;
    uvn_dgemv_t dgemv;
    uvn_ddot_t ddot;
    uvn_dsyrk_t dsyrk;
    uvn_daxpy_t daxpy;
    uvn_npl_dgesv_t npl_dgesv;
    uvn_npl_dgetrf_t npl_dgetrf;
    uvn_npl_dpotrf_t npl_dpotrf;
    uvn_npl_dsyevd_t npl_dsyevd;
    uvn_dpotrf_t dpotrf;
    uvn_dtrsm_t dtrsm;
    uvn_dgesv_t dgesv;
} uvn_blas_t;

/* Fill *b from a dict {"np_dgemm": address, ...} (engine.native.blas.all_addresses()).
 * Returns 0, or -1 with a Python exception set. */
static int uvn_blas_bind(PyObject *addresses, uvn_blas_t *b)
{
    enum { N = 12 };
    static const char *keys[N] = {"np_dgemm", "np_dgemv", "np_ddot", "np_dsyrk", "np_daxpy",
                                  "npl_dgesv", "npl_dgetrf", "npl_dpotrf", "npl_dsyevd",
                                  "sp_dpotrf", "sp_dtrsm", "sp_dgesv"};
    void *ptr[N];
    if (!PyDict_Check(addresses)) {
        PyErr_SetString(PyExc_TypeError, "_bind needs a dict of routine addresses");
        return -1;
    }
    for (int i = 0; i < N; i++) {
        PyObject *v = PyDict_GetItemString(addresses, keys[i]);
        if (v == NULL) {
            PyErr_Format(PyExc_KeyError, "routine address %s missing", keys[i]);
            return -1;
        }
        ptr[i] = PyLong_AsVoidPtr(v);
        if (ptr[i] == NULL) {
            if (!PyErr_Occurred())
                PyErr_Format(PyExc_ValueError, "routine address %s is null", keys[i]);
            return -1;
        }
    }
    b->dgemm = (uvn_dgemm_t)ptr[0];
    b->dgemv = (uvn_dgemv_t)ptr[1];
    b->ddot = (uvn_ddot_t)ptr[2];
    b->dsyrk = (uvn_dsyrk_t)ptr[3];
    b->daxpy = (uvn_daxpy_t)ptr[4];
    b->npl_dgesv = (uvn_npl_dgesv_t)ptr[5];
    b->npl_dgetrf = (uvn_npl_dgetrf_t)ptr[6];
    b->npl_dpotrf = (uvn_npl_dpotrf_t)ptr[7];
    b->npl_dsyevd = (uvn_npl_dsyevd_t)ptr[8];
    b->dpotrf = (uvn_dpotrf_t)ptr[9];
    b->dtrsm = (uvn_dtrsm_t)ptr[10];
    b->dgesv = (uvn_dgesv_t)ptr[11];
    return 0;
}

#endif
