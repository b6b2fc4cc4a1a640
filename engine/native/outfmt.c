/* engine.native.outfmt: the text of one .OUT cycle block in one call (issue 14).
 *
 * render_rows(rows, dumps, format_text, format_value) -> str | None is the compiled twin of
 * engine.io.outlog._render_rows_py: rows are (prefix, keys, values) tuples, each line written
 * as prefix + " key=value" per field, every value in the form format_value gives it
 * (engine/io/outlog.py, docs/PERFORMANCE.md "Output unchanged, bit for bit"):
 *
 *   exact float  its repr: PyOS_double_to_string(x, 'r', 0, Py_DTSF_ADD_DOT_0, NULL), the very
 *                call float.__repr__ makes; or, when `dumps` (orjson.dumps, probed by the
 *                Python against repr) is given, dumps' text of the whole list of floats, each
 *                number kept only in the positional form the probe checked (digits, '-', one
 *                point, no "0.0000"), every other one through repr as above;
 *   exact int    its decimal digits (repr);  bool  "1" / "0";  None  "-";
 *   exact str    bare, or JSON-quoted (json.encoder.encode_basestring) when it has a blank,
 *                '"', '=' or '\' or would read back as a number; decided here for the ASCII
 *                words whose answer is certain (a character that float() never takes: bare;
 *                digits only: quoted), else by the Python `format_text` (outlog._format_text);
 *   anything else  format_value(value) (the Python's general formatter).
 *
 * None is returned (nothing written, no error) for rows the Python path must handle itself:
 * not (str, tuple, tuple) rows, keys that are not exact str, keys and values of different
 * lengths, text that is not valid UTF-8 (lone surrogates), a formatter giving a non-str.
 * No floating-point arithmetic is done here: only texts are copied (but see cycle_rows below:
 * the three products, square roots and '.3f' texts cycle_block itself computes).
 *
 * cycle_rows(r, consts) / cycle_text(r, consts, dumps, format_text, format_value) build the
 * rows of a whole cycle block from the CycleResult (engine.run.records.cycle_block's twin) and
 * render them as render_rows does: the session's .OUT block in one call (section below).
 * cycle_text does not call `dumps`: where it is given (the fast writer allowed), each float is
 * written by short_repr, the kernel's own shortest digits (exact-integer Ryu, section "short
 * float text"), which writes repr's text where it writes one (checked by probes at first use;
 * else, and for the exponent forms, repr's own routine); NumPy arrays of float64 (VCVs, the KF
 * state and P's diagonal, the LS statistics) are read from their data (uvn_numpy.h np_direct)
 * instead of through tolist().
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <datetime.h>
#include "uvn_numpy.h"
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <errno.h>
#include <limits.h>
#include <unistd.h>

#ifndef UVN_SOURCE_DIGEST
#define UVN_SOURCE_DIGEST "unknown"
#endif

#define FALLBACK (-2) /* let the Python path render the block */

/* ------------------------------------------------------------------------- output buffer */

typedef struct {
    char *p;
    Py_ssize_t n, cap;
    int heap;  /* p is PyMem memory (else the caller's stack array) */
    int ascii; /* nothing but ASCII written so far */
} buf_t;

static int buf_grow(buf_t *b, Py_ssize_t extra)
{
    Py_ssize_t cap = b->cap * 2;
    while (cap < b->n + extra)
        cap *= 2;
    char *p;
    if (b->heap) {
        p = PyMem_Realloc(b->p, (size_t)cap);
    } else {
        p = PyMem_Malloc((size_t)cap);
        if (p != NULL)
            memcpy(p, b->p, (size_t)b->n);
    }
    if (p == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    b->p = p;
    b->cap = cap;
    b->heap = 1;
    return 0;
}

static inline int buf_reserve(buf_t *b, Py_ssize_t extra)
{
    return b->n + extra <= b->cap ? 0 : buf_grow(b, extra);
}

static inline int buf_put(buf_t *b, const char *s, Py_ssize_t n)
{
    if (buf_reserve(b, n) < 0)
        return -1;
    memcpy(b->p + b->n, s, (size_t)n);
    b->n += n;
    return 0;
}

static inline int buf_putc(buf_t *b, char c)
{
    if (buf_reserve(b, 1) < 0)
        return -1;
    b->p[b->n++] = c;
    return 0;
}

/* The UTF-8 of str `s` (ASCII: its own bytes). FALLBACK if it cannot be encoded. */
static inline int buf_put_str(buf_t *b, PyObject *s)
{
#if PY_VERSION_HEX < 0x030C0000
    if (PyUnicode_READY(s) < 0)
        return -1;
#endif
    if (PyUnicode_IS_ASCII(s))
        return buf_put(b, (const char *)PyUnicode_DATA(s), PyUnicode_GET_LENGTH(s));
    Py_ssize_t n;
    const char *u = PyUnicode_AsUTF8AndSize(s, &n);
    if (u == NULL) {
        if (PyErr_ExceptionMatches(PyExc_UnicodeEncodeError)) {
            PyErr_Clear();
            return FALLBACK;
        }
        return -1;
    }
    b->ascii = 0;
    return buf_put(b, u, n);
}

/* ------------------------------------------------------------------------- values */

/* repr(x) of a float: the call float.__repr__ makes (shortest round-trip digits). */
static int buf_put_repr(buf_t *b, double x)
{
    char *s = PyOS_double_to_string(x, 'r', 0, Py_DTSF_ADD_DOT_0, NULL);
    if (s == NULL)
        return -1;
    int rc = buf_put(b, s, (Py_ssize_t)strlen(s));
    PyMem_Free(s);
    return rc;
}

/* ------------------------------------------------------------------------- short float text */

/* repr(x) of the floats that repr writes positionally (1e-4 <= |x| < 1e16, normal), by the
 * digit search of Ryu (Ulf Adams, PLDI 2018, "Ryu: fast float-to-string conversion", step 4)
 * on exact integers: x = mv * 2^e2 (mv = 4 m2) and its rounding interval (mm, mp) * 2^e2,
 * scaled by 10^-e10 = 5^i * 2^(-e2-q): mv * 5^i / 2^q, which for these x is below 2^113 and
 * is held whole in 128 bits. Ryu's shifted table products become exact floors here, and
 * "are the cut digits all zero" is an exact remainder test, so the search is the shortest
 * digits in the interval (bounds inside when m2 is even, as round-half-even reads back),
 * nearest to x, ties to an even digit: what repr's dtoa (mode 0) writes. 0 for every other
 * x (subnormals, the exponent forms): the caller uses repr's own routine. Zeros, nan and inf
 * are written as repr writes them ("0.0", "-0.0", "nan" whatever its sign, "inf", "-inf").
 * tests/native/test_outfmt.py compares it with repr on random bits, ties and boundaries, and
 * short_ok() checks probes at first use (on a difference, repr's routine writes every float). */
static uint64_t POW5[28];

static void init_pow5(void)
{
    POW5[0] = 1;
    for (int i = 1; i < 28; i++)
        POW5[i] = POW5[i - 1] * 5;
}

static const uint64_t POW10[20] = {
    UINT64_C(1), UINT64_C(10), UINT64_C(100), UINT64_C(1000), UINT64_C(10000),
    UINT64_C(100000), UINT64_C(1000000), UINT64_C(10000000), UINT64_C(100000000),
    UINT64_C(1000000000), UINT64_C(10000000000), UINT64_C(100000000000),
    UINT64_C(1000000000000), UINT64_C(10000000000000), UINT64_C(100000000000000),
    UINT64_C(1000000000000000), UINT64_C(10000000000000000), UINT64_C(100000000000000000),
    UINT64_C(1000000000000000000), UINT64_C(10000000000000000000)};

/* The number of decimal digits of v (1 for 0). */
static inline int dec_len(uint64_t v)
{
    int t = ((64 - __builtin_clzll(v | 1)) * 1233) >> 12;
    return t + (t < 20 && v >= POW10[t]);
}

static const char DIGITS2[201] =
    "00010203040506070809101112131415161718192021222324252627282930313233343536373839"
    "40414243444546474849505152535455565758596061626364656667686970717273747576777879"
    "8081828384858687888990919293949596979899";

/* The 8 decimal digits of v < 10^8 (leading zeros included) into o[0..8), all at once in
 * one 64-bit word: v split into two 4-digit halves (32-bit lanes), each into two 2-digit
 * pairs (16-bit lanes: x * 10486 >> 20 is x / 100 for x < 10^4), each pair into two digits
 * (bytes: y * 103 >> 10 is y / 10 for y < 100); checked on every v < 10^8 against the
 * digits by / and % (the 2026-12-03 change that brought it in). */
static inline void digits8(uint32_t v, char *o)
{
    const uint64_t hi4 = v / 10000, lo4 = v - hi4 * 10000;
    const uint64_t x = hi4 | (lo4 << 32);
    const uint64_t y = ((x * 10486) >> 20) & UINT64_C(0x0000007F0000007F);
    const uint64_t w = y | ((x - y * 100) << 16);
    const uint64_t t = ((w * 103) >> 10) & UINT64_C(0x000F000F000F000F);
    uint64_t bytes = (t | ((w - t * 10) << 8)) + UINT64_C(0x3030303030303030);
#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
    bytes = __builtin_bswap64(bytes); /* the first digit in the lowest byte: first in memory */
#endif
    memcpy(o, &bytes, 8);
}

/* The low 64 bits of v >> q for 0 <= q < 64: on x86-64 one SHRD (what gcc emits for the
 * 128-bit shift, without the fix-up for q >= 64 it must add as it does not know q < 64). */
static inline uint64_t shr128(unsigned __int128 v, int q)
{
#if defined(__x86_64__) && defined(__GNUC__)
    uint64_t lo = (uint64_t)v;
    __asm__("shrdq %%cl, %1, %0" : "+r"(lo) : "r"((uint64_t)(v >> 64)), "c"(q) : "cc");
    return lo;
#else
    return (uint64_t)(v >> q);
#endif
}

/* The text of x into o (at least 48 bytes: the copies below are of fixed sizes, the text at
 * most 23 bytes); its length, or 0 (not handled here). */
static int short_repr(double x, char *o)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    const uint64_t mant = bits & ((UINT64_C(1) << 52) - 1);
    const int ex = (int)((bits >> 52) & 0x7ff);
    if (ex == 0x7ff) { /* as repr: "nan" whatever its sign, "inf", "-inf" */
        if (mant != 0) {
            memcpy(o, "nan", 3);
            return 3;
        }
        memcpy(o, "-inf" + !(bits >> 63), 4 - !(bits >> 63));
        return 4 - !(bits >> 63);
    }
    if (ex == 0) {
        if (mant != 0)
            return 0; /* subnormal: written with an exponent */
        memcpy(o, "-0.0" + !(bits >> 63), 4 - !(bits >> 63));
        return 4 - !(bits >> 63);
    }
    const int e2 = ex - 1075 - 2;
    if (e2 >= 0 || e2 < -75)
        return 0;
    const uint64_t m2 = (UINT64_C(1) << 52) | mant;
    const int accept = (m2 & 1) == 0;
    const uint64_t mv = 4 * m2, mp = mv + 2, mm = mv - 1 - (mant != 0 || ex <= 1);
    const int q = (int)(((uint32_t)(-e2) * 732923u) >> 20) - (-e2 > 1);
    const int i = -e2 - q, e10 = q + e2;
    /* -e2 <= 75: q <= 51, i <= 24 (5^i < 2^56), the products < 2^111 */
    const uint64_t p5 = POW5[i], mask = (UINT64_C(1) << q) - 1;
    const unsigned __int128 pr = (unsigned __int128)mv * p5, pp = (unsigned __int128)mp * p5,
                            pm = (unsigned __int128)mm * p5;
    if ((uint64_t)(pp >> 64) >> q) /* pp >> q (q <= 51) above 64 bits */
        return 0;
    uint64_t vr = shr128(pr, q), vp = shr128(pp, q), vm = shr128(pm, q); /* q <= 51 */
    int vr_tz = ((uint64_t)pr & mask) == 0, vm_tz = accept && ((uint64_t)pm & mask) == 0;
    if (!accept && ((uint64_t)pp & mask) == 0)
        vp--; /* the upper bound itself does not read back as x */
    int removed = 0;
    unsigned last = 0;
    uint64_t out;
    if (vm_tz || vr_tz) {
        for (;;) {
            uint64_t vp10 = vp / 10, vm10 = vm / 10;
            if (vp10 <= vm10)
                break;
            unsigned vm_mod = (unsigned)(vm - 10 * vm10);
            uint64_t vr10 = vr / 10;
            unsigned vr_mod = (unsigned)(vr - 10 * vr10);
            vm_tz &= vm_mod == 0;
            vr_tz &= last == 0;
            last = vr_mod;
            vr = vr10;
            vp = vp10;
            vm = vm10;
            removed++;
        }
        if (vm_tz) {
            for (;;) {
                uint64_t vm10 = vm / 10;
                unsigned vm_mod = (unsigned)(vm - 10 * vm10);
                if (vm_mod != 0)
                    break;
                uint64_t vr10 = vr / 10;
                unsigned vr_mod = (unsigned)(vr - 10 * vr10);
                vr_tz &= last == 0;
                last = vr_mod;
                vr = vr10;
                vp /= 10;
                vm = vm10;
                removed++;
            }
        }
        if (vr_tz && last == 5 && vr % 2 == 0)
            last = 4; /* exactly half way: to the even digit */
        out = vr + ((vr == vm && (!accept || !vm_tz)) || last >= 5);
    } else {
        int up = 0;
        uint64_t vp100 = vp / 100, vm100 = vm / 100;
        if (vp100 > vm100) {
            uint64_t vr100 = vr / 100;
            up = vr - 100 * vr100 >= 50;
            vr = vr100;
            vp = vp100;
            vm = vm100;
            removed += 2;
        }
        for (;;) {
            uint64_t vp10 = vp / 10, vm10 = vm / 10;
            if (vp10 <= vm10)
                break;
            uint64_t vr10 = vr / 10;
            up = vr - 10 * vr10 >= 5;
            vr = vr10;
            vp = vp10;
            vm = vm10;
            removed++;
        }
        out = vr + (vr == vm || up);
    }
    const int n = dec_len(out), decpt = n + e10 + removed;
    if (decpt < -3 || decpt > 16)
        return 0;
    /* the n digits, right-aligned in d[0..24) by 8-digit blocks (digits8), from ds on; then
     * copied in fixed sizes (within d's 48 bytes) */
    char d[48];
    if (n <= 8) {
        digits8((uint32_t)out, d + 16);
    } else {
        uint64_t hi = out / 100000000;
        digits8((uint32_t)(out - hi * 100000000), d + 16);
        if (n <= 16) {
            digits8((uint32_t)hi, d + 8);
        } else {
            uint64_t top = hi / 100000000; /* one digit: out < 2^64 has at most 20, and */
            digits8((uint32_t)(hi - top * 100000000), d + 8); /* n = 17 here (mv 5^i/2^q) */
            if (top < 10)
                d[7] = (char)('0' + top);
            else
                digits8((uint32_t)top, d);
        }
    }
    const char *ds = d + 24 - n;
    char *p = o;
    *p = '-';
    p += bits >> 63;
    if (decpt <= 0) { /* "0." + -decpt zeros (<= 3) + the digits */
        memcpy(p, "0.000", 5);
        p += 2 - decpt;
        memcpy(p, ds, 20);
        p += n;
    } else if (decpt < n) { /* the digits with the point after decpt of them */
        memcpy(p, ds, 20);
        p[decpt] = '.';
        memcpy(p + decpt + 1, ds + decpt, 20);
        p += n + 1;
    } else { /* the digits, decpt - n zeros (decpt <= 16), ".0" */
        memcpy(p, ds, 20);
        memcpy(p + n, "0000000000000000", 16);
        p += decpt;
        memcpy(p, ".0", 2);
        p += 2;
    }
    return (int)(p - o);
}

/* format(x, ".3f") (PyOS_double_to_string(x, 'f', 3, 0): dtoa's correctly rounded digits,
 * ties to even) for finite |x| < 2^53, on exact integers: x = m 2^e, r = m 1000 2^e rounded
 * half to even (m 1000 < 2^63), written as r / 1000 "." r % 1000 with x's sign ("-0.000"
 * too). 0 for nan, inf and |x| >= 2^53 (repr's routine writes those). o: 32 bytes. */
static int fixed3(double x, char *o)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    const uint64_t mant = bits & ((UINT64_C(1) << 52) - 1);
    const int ex = (int)((bits >> 52) & 0x7ff);
    if (ex == 0x7ff)
        return 0;
    const uint64_t m = ex == 0 ? mant : mant | (UINT64_C(1) << 52);
    const int e = ex == 0 ? -1074 : ex - 1075;
    if (e > 0)
        return 0;
    const uint64_t p = m * 1000;
    uint64_t r;
    if (e == 0) {
        r = p;
    } else if (-e >= 64) {
        r = 0; /* p < 2^63 <= half of 2^-e: below one half */
    } else {
        const int k = -e;
        const uint64_t rem = p & ((UINT64_C(1) << k) - 1), half = UINT64_C(1) << (k - 1);
        r = p >> k;
        r += rem > half || (rem == half && (r & 1));
    }
    char d[24], *q = d + sizeof d;
    unsigned frac = (unsigned)(r % 1000);
    uint64_t ip = r / 1000;
    q -= 3;
    q[0] = (char)('0' + frac / 100);
    q[1] = (char)('0' + frac / 10 % 10);
    q[2] = (char)('0' + frac % 10);
    *--q = '.';
    do {
        *--q = (char)('0' + ip % 10);
        ip /= 10;
    } while (ip);
    if (bits >> 63)
        *--q = '-';
    int n = (int)(d + sizeof d - q);
    memcpy(o, q, (size_t)n);
    return n;
}

/* 1: short_repr wrote every probe as repr does, 0: it did not (repr's routine for every
 * float), -1: not checked yet. */
static int short_state = -1;

/* Do short_repr and fixed3 write what PyOS_double_to_string writes (repr, format(x, ".3f")),
 * on boundaries, ties and 128 pseudo-random floats of the positional range? Checked once, at
 * the first cycle_text (else every float goes through PyOS_double_to_string). */
static int short_ok(void)
{
    if (short_state >= 0)
        return short_state;
    static const double edges[] = {
        0.0, -0.0, 1.0, -1.0, 0.1, 0.2, 0.3, 2.5, 100.0, 1e-4, -1e-4, 0.00010000000000000002,
        9999999999999998.0, 1e15, 123.0, 52.84232512345678, 4.531599494383838, -31615.4,
        5857300.165, 101065508335255.125, 101065508335255.375, -101065508335255.625,
        123456789012345.875, 4503599627370496.5, 9007199254740991.0, 0.5, 0.25, 0.125,
        1.0 / 3.0, 2.0 / 3.0, 123456789.123, 1e-3, 1e16, 1e-5, 5e-324, NAN, INFINITY, -INFINITY};
    int ok = 1;
    uint64_t s = UINT64_C(0x9E3779B97F4A7C15);
    for (int k = 0; ok && k < (int)(sizeof edges / sizeof edges[0]) + 128; k++) {
        double x;
        if (k < (int)(sizeof edges / sizeof edges[0])) {
            x = edges[k];
        } else { /* xorshift64: sign, exponent of 1e-4 .. 1e16, random mantissa */
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            uint64_t bits = (s & ((UINT64_C(1) << 52) - 1)) |
                            ((uint64_t)(1010 + (s >> 52) % 67) << 52) | (s & (UINT64_C(1) << 63));
            memcpy(&x, &bits, sizeof x);
        }
        char t[48];
        for (int mode = 0; ok && mode < 2; mode++) { /* repr, then format(x, ".3f") */
            int n = mode == 0 ? short_repr(x, t) : fixed3(x, t);
            if (n == 0)
                continue;
            char *r = mode == 0 ? PyOS_double_to_string(x, 'r', 0, Py_DTSF_ADD_DOT_0, NULL)
                                : PyOS_double_to_string(x, 'f', 3, 0, NULL);
            if (r == NULL) {
                PyErr_Clear();
                ok = 0;
                break;
            }
            ok = (size_t)n == strlen(r) && memcmp(t, r, (size_t)n) == 0;
            PyMem_Free(r);
        }
    }
    return short_state = ok;
}

/* The texts short_repr wrote last, by the float's bits (a direct-mapped table of 512): a
 * cycle block writes many a float twice (the LOP's calc and the LSE's lat, the KF's x and
 * the MPP's, the TEST bounds, one cycle to the next; ~20 % of the demo's floats), and the
 * text of the same bits is the same text. t[23] is the text's length (<= 23), 0: empty. */
#define FTEXT_BITS 9
typedef struct {
    uint64_t bits;
    char t[24];
} ftext_t;
static ftext_t FTEXT[1 << FTEXT_BITS];

/* short_repr(x, o) through FTEXT (o: at least 48 bytes; up to 24 copied on a hit). */
static inline int short_repr_cached(double x, char *o)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    ftext_t *e = &FTEXT[(bits * UINT64_C(0x9E3779B97F4A7C15)) >> (64 - FTEXT_BITS)];
    if (e->bits == bits && e->t[23] != 0) {
        memcpy(o, e->t, 24);
        return e->t[23];
    }
    int n = short_repr(x, o);
    if (n > 0 && n <= 23) {
        e->bits = bits;
        memcpy(e->t, o, 23);
        e->t[23] = (char)n;
    }
    return n;
}

/* repr(x): short_repr where it writes x, else repr's own routine. */
static int buf_put_float(buf_t *b, double x)
{
    if (buf_reserve(b, 48) < 0)
        return -1;
    int n = short_state == 1 ? short_repr_cached(x, b->p + b->n) : 0;
    if (n == 0)
        return buf_put_repr(b, x);
    b->n += n;
    return 0;
}

/* Classes of a byte in a number of dumps' text: 0 a digit or '-', 1 the point, 2 anything
 * else. */
static unsigned char NUM_CLS[256];

/* A number of dumps' text in the positional form repr shares (outlog._plain_float_text):
 * only digits and '-', exactly one point, and no "0.0000" (< 1e-4 written positionally). With
 * one point, "0.0000" can only stand around it: a '0' before it and four '0' after it. */
static int plain_float_text(const char *t, Py_ssize_t n)
{
    unsigned other = 0;
    Py_ssize_t dots = 0, dot = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        unsigned k = NUM_CLS[(unsigned char)t[i]];
        other |= k & 2;
        dots += k & 1;
        dot = k == 1 ? i : dot;
    }
    if (other || dots != 1)
        return 0;
    return !(dot >= 1 && dot + 4 < n && t[dot - 1] == '0' && t[dot + 1] == '0' &&
             t[dot + 2] == '0' && t[dot + 3] == '0' && t[dot + 4] == '0');
}

/* Character classes of ASCII for the str rule of outlog._format_text. */
enum { NEEDS_QUOTES = 1, NEVER_IN_A_NUMBER = 2, DIGIT = 4 };
static unsigned char CLS[128];

static void init_classes(void)
{
    /* outlog._NEEDS_QUOTES, r'[\s"=\\]', on ASCII: str.isspace() characters, '"', '=', '\' */
    static const char needs[] = "\t\n\x0b\x0c\r\x1c\x1d\x1e\x1f \"=\\";
    /* outlog._NEVER_IN_A_NUMBER on ASCII: what float() rejects wherever it stands */
    static const char never[] =
        "!#$%&'()*,/:;<>?@BCDGHJKLMOPQRSUVWXZ[]^`bcdghjklmopqrsuvwxz{|}~";
    for (const char *c = needs; *c; c++)
        CLS[(unsigned char)*c] |= NEEDS_QUOTES;
    for (const char *c = never; *c; c++)
        CLS[(unsigned char)*c] |= NEVER_IN_A_NUMBER;
    for (int c = '0'; c <= '9'; c++)
        CLS[c] |= DIGIT;
    for (int c = 0; c < 256; c++)
        NUM_CLS[c] = ((c >= '0' && c <= '9') || c == '-') ? 0 : c == '.' ? 1 : 2;
}

/* How outlog._format_text writes the ASCII word u[0:n]: 0 bare, 1 JSON-quoted, -1 not
 * decided here (a word float() might read, e.g. "1e5", "nan", "1_0": the Python decides). */
static int ascii_text_form(const unsigned char *u, Py_ssize_t n)
{
    if (n == 0 || (n == 1 && u[0] == '-'))
        return 1;
    int never = 0, digits = 1;
    for (Py_ssize_t i = 0; i < n; i++) {
        unsigned char k = CLS[u[i]];
        if (k & NEEDS_QUOTES)
            return 1;
        if (k & NEVER_IN_A_NUMBER)
            never = 1;
        if (!(k & DIGIT))
            digits = 0;
    }
    if (never)
        return 0;
    return digits ? 1 : -1;
}

/* json.encoder.encode_basestring (the C encoder, ensure_ascii off) of an ASCII word. */
static int buf_put_json_ascii(buf_t *b, const unsigned char *u, Py_ssize_t n)
{
    static const char hex[] = "0123456789abcdef";
    if (buf_reserve(b, 6 * n + 2) < 0)
        return -1;
    char *o = b->p + b->n;
    *o++ = '"';
    for (Py_ssize_t i = 0; i < n; i++) {
        unsigned char c = u[i];
        switch (c) {
        case '\\': *o++ = '\\'; *o++ = '\\'; break;
        case '"': *o++ = '\\'; *o++ = '"'; break;
        case '\b': *o++ = '\\'; *o++ = 'b'; break;
        case '\f': *o++ = '\\'; *o++ = 'f'; break;
        case '\n': *o++ = '\\'; *o++ = 'n'; break;
        case '\r': *o++ = '\\'; *o++ = 'r'; break;
        case '\t': *o++ = '\\'; *o++ = 't'; break;
        default:
            if (c <= 0x1f) {
                *o++ = '\\'; *o++ = 'u'; *o++ = '0'; *o++ = '0';
                *o++ = hex[(c >> 4) & 0xf];
                *o++ = hex[c & 0xf];
            } else {
                *o++ = (char)c;
            }
        }
    }
    *o++ = '"';
    b->n = o - b->p;
    return 0;
}

/* The result of a Python formatter: written if it is a str, else FALLBACK. */
static int buf_put_result(buf_t *b, PyObject *r)
{
    if (r == NULL)
        return -1;
    int rc = PyUnicode_Check(r) ? buf_put_str(b, r) : FALLBACK;
    Py_DECREF(r);
    return rc;
}

/* ascii_text_form of the short ASCII str values written last, by the str object (a
 * direct-mapped table of 64 holding a reference to each, so that an address stays its str's
 * while it is in the table; a str never changes): the words of a block (verdicts, system
 * and pattern names, the datum, "ON", "KF") are the same objects cycle after cycle. */
#define TFORM_N 64
#define TFORM_MAX_LEN 32
static struct {
    PyObject *s;
    int form;
} TFORM[TFORM_N];

static inline int text_form_cached(PyObject *s, const unsigned char *u, Py_ssize_t n)
{
    if (n > TFORM_MAX_LEN)
        return ascii_text_form(u, n);
    size_t h = ((uintptr_t)s >> 4) % TFORM_N;
    if (TFORM[h].s == s)
        return TFORM[h].form;
    int form = ascii_text_form(u, n);
    Py_XSETREF(TFORM[h].s, Py_NewRef(s));
    TFORM[h].form = form;
    return form;
}

/* An exact str value as outlog._format_text writes it. */
static int buf_put_text(buf_t *b, PyObject *s, PyObject *format_text)
{
#if PY_VERSION_HEX < 0x030C0000
    if (PyUnicode_READY(s) < 0)
        return -1;
#endif
    if (PyUnicode_IS_ASCII(s)) {
        const unsigned char *u = (const unsigned char *)PyUnicode_DATA(s);
        Py_ssize_t n = PyUnicode_GET_LENGTH(s);
        int form = text_form_cached(s, u, n);
        if (form == 0)
            return buf_put(b, (const char *)u, n);
        if (form == 1)
            return buf_put_json_ascii(b, u, n);
    }
    return buf_put_result(b, PyObject_CallOneArg(format_text, s));
}

/* One value that is not an exact float (those are written from the float texts). */
static int buf_put_value(buf_t *b, PyObject *v, PyObject *format_text, PyObject *format_value)
{
    if (PyUnicode_CheckExact(v))
        return buf_put_text(b, v, format_text);
    if (v == Py_None)
        return buf_putc(b, '-');
    if (PyBool_Check(v))
        return buf_putc(b, v == Py_True ? '1' : '0');
    if (PyLong_CheckExact(v)) {
        int overflow = 0;
        long long i = PyLong_AsLongLongAndOverflow(v, &overflow);
        if (i == -1 && PyErr_Occurred())
            return -1;
        if (!overflow) { /* the decimal digits, as int.__repr__ */
            char s[24], *e = s + sizeof s, *o = e;
            unsigned long long m = i < 0 ? 0ULL - (unsigned long long)i : (unsigned long long)i;
            do {
                *--o = (char)('0' + m % 10);
                m /= 10;
            } while (m);
            if (i < 0)
                *--o = '-';
            return buf_put(b, o, e - o);
        }
        return buf_put_result(b, PyObject_Repr(v));
    }
    return buf_put_result(b, PyObject_CallOneArg(format_value, v));
}

/* ------------------------------------------------------------------------- render_rows */

typedef struct {
    Py_ssize_t at, len;
} span_t;

#define STACK_FLOATS 256

/* Check the rows' shape; count the values and the exact floats. 0, or FALLBACK. */
static int check_rows(PyObject *rows, Py_ssize_t *n_float)
{
    Py_ssize_t nr = PyList_GET_SIZE(rows), nf = 0;
    for (Py_ssize_t r = 0; r < nr; r++) {
        PyObject *row = PyList_GET_ITEM(rows, r);
        if (!PyTuple_CheckExact(row) || PyTuple_GET_SIZE(row) != 3)
            return FALLBACK;
        PyObject *prefix = PyTuple_GET_ITEM(row, 0), *keys = PyTuple_GET_ITEM(row, 1),
                 *values = PyTuple_GET_ITEM(row, 2);
        if (!PyUnicode_CheckExact(prefix) || !PyTuple_CheckExact(keys) ||
            !PyTuple_CheckExact(values) || PyTuple_GET_SIZE(keys) != PyTuple_GET_SIZE(values))
            return FALLBACK;
        for (Py_ssize_t i = 0, n = PyTuple_GET_SIZE(keys); i < n; i++) {
            if (!PyUnicode_CheckExact(PyTuple_GET_ITEM(keys, i)))
                return FALLBACK;
            nf += PyFloat_CheckExact(PyTuple_GET_ITEM(values, i));
        }
    }
    *n_float = nf;
    return 0;
}

/* dumps(list of the exact floats) -> its bytes (new reference) and the span of each number;
 * NULL with no error set when dumps' text does not have one number per float. */
static PyObject *dump_floats(PyObject *rows, Py_ssize_t nf, PyObject *dumps, span_t *spans)
{
    PyObject *list = PyList_New(nf);
    if (list == NULL)
        return NULL;
    Py_ssize_t k = 0;
    for (Py_ssize_t r = 0, nr = PyList_GET_SIZE(rows); r < nr; r++) {
        PyObject *values = PyTuple_GET_ITEM(PyList_GET_ITEM(rows, r), 2);
        for (Py_ssize_t i = 0, n = PyTuple_GET_SIZE(values); i < n; i++) {
            PyObject *v = PyTuple_GET_ITEM(values, i);
            if (PyFloat_CheckExact(v)) {
                Py_INCREF(v);
                PyList_SET_ITEM(list, k++, v);
            }
        }
    }
    PyObject *out = PyObject_CallOneArg(dumps, list);
    Py_DECREF(list);
    if (out == NULL)
        return NULL;
    if (!PyBytes_Check(out)) {
        Py_DECREF(out);
        return NULL;
    }
    /* As the Python: drop the first and last byte ('[' and ']'), split at ','. */
    const char *t = PyBytes_AS_STRING(out);
    Py_ssize_t end = PyBytes_GET_SIZE(out) - 1, at = 1;
    k = 0;
    while (end >= 1 && k < nf) {
        const char *comma = memchr(t + at, ',', (size_t)(end - at));
        Py_ssize_t stop = comma != NULL ? comma - t : end;
        spans[k].at = at;
        spans[k].len = stop - at;
        k++;
        at = stop + 1;
        if (comma == NULL)
            break;
    }
    if (k == nf && at <= end) /* more numbers than floats */
        k = -1;
    if (k != nf) {
        Py_DECREF(out);
        return NULL;
    }
    return out;
}

/* Write every row; the k-th exact float from span k of `dumped` where that is a plain
 * positional number, else by repr. 0, -1 (error) or FALLBACK. */
static int write_rows(buf_t *b, PyObject *rows, PyObject *dumped, const span_t *spans,
                      PyObject *format_text, PyObject *format_value)
{
    const char *t = dumped != NULL ? PyBytes_AS_STRING(dumped) : NULL;
    Py_ssize_t k = 0;
    for (Py_ssize_t r = 0, nr = PyList_GET_SIZE(rows); r < nr; r++) {
        PyObject *row = PyList_GET_ITEM(rows, r);
        PyObject *keys = PyTuple_GET_ITEM(row, 1), *values = PyTuple_GET_ITEM(row, 2);
        int rc = buf_put_str(b, PyTuple_GET_ITEM(row, 0));
        if (rc)
            return rc;
        for (Py_ssize_t i = 0, n = PyTuple_GET_SIZE(keys); i < n; i++) {
            PyObject *v = PyTuple_GET_ITEM(values, i);
            if (buf_putc(b, ' ') < 0)
                return -1;
            if ((rc = buf_put_str(b, PyTuple_GET_ITEM(keys, i))) != 0)
                return rc;
            if (buf_putc(b, '=') < 0)
                return -1;
            if (PyFloat_CheckExact(v)) {
                if (t != NULL && plain_float_text(t + spans[k].at, spans[k].len))
                    rc = buf_put(b, t + spans[k].at, spans[k].len);
                else
                    rc = buf_put_repr(b, PyFloat_AS_DOUBLE(v));
                k++;
            } else {
                rc = buf_put_value(b, v, format_text, format_value);
            }
            if (rc)
                return rc;
        }
    }
    return 0;
}

/* The text of `rows` (a list), or None (a new reference to it) where the Python must write
 * them; NULL with an error set on an error. */
static PyObject *render_list(PyObject *rows, PyObject *dumps, PyObject *format_text,
                             PyObject *format_value)
{
    Py_ssize_t nf = 0;
    if (check_rows(rows, &nf) == FALLBACK)
        Py_RETURN_NONE;

    span_t stack_spans[STACK_FLOATS], *spans = stack_spans;
    PyObject *dumped = NULL, *result = NULL;
    char stack_buf[8192];
    buf_t b = {stack_buf, 0, (Py_ssize_t)sizeof stack_buf, 0, 1};
    int rc = 0;

    if (dumps != Py_None && nf > 0) {
        if (nf > STACK_FLOATS) {
            spans = PyMem_Malloc((size_t)nf * sizeof(span_t));
            if (spans == NULL)
                return PyErr_NoMemory();
        }
        dumped = dump_floats(rows, nf, dumps, spans);
        if (dumped == NULL && PyErr_Occurred())
            goto done;
    }
    rc = write_rows(&b, rows, dumped, spans, format_text, format_value);
    if (rc == -1)
        goto done;
    if (rc == FALLBACK) {
        result = Py_NewRef(Py_None);
        goto done;
    }
    if (b.ascii) {
        result = PyUnicode_New(b.n, 127);
        if (result != NULL)
            memcpy(PyUnicode_DATA(result), b.p, (size_t)b.n);
    } else {
        result = PyUnicode_DecodeUTF8(b.p, b.n, "strict");
    }
done:
    Py_XDECREF(dumped);
    if (spans != stack_spans)
        PyMem_Free(spans);
    if (b.heap)
        PyMem_Free(b.p);
    return result;
}

static PyObject *render_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError,
                        "render_rows(rows, dumps, format_text, format_value) takes 4 arguments");
        return NULL;
    }
    if (!PyList_CheckExact(args[0]))
        Py_RETURN_NONE;
    return render_list(args[0], args[1], args[2], args[3]);
}

/* ------------------------------------------------------------------------- cycle_rows */

/* cycle_rows(r, consts) is the compiled twin of engine.run.records.cycle_block followed by the
 * rows OutLogWriter.write_cycle hands to render_rows: the same (prefix, keys, values) rows, the
 * values the very objects cycle_block puts there (attribute reads of the CycleResult), the
 * few it computes computed by the same operations: the 95 % semi-axes by `_K95 * a` (the float
 * multiplication of PyNumber_Multiply), the KF standard deviations by sqrt (what math.sqrt
 * calls) with the same rule for 0, negatives and NaN, the TEST line's `"{:.3f}".format` of the
 * LS statistics by PyOS_double_to_string(x, 'f', 3, 0) (float.__format__'s own call) and the
 * time stamp by the integer formatting of records._utc_text (other years: its Python).
 * cycle_text(r, consts, dumps, format_text, format_value) is render_rows of those rows.
 * Both give None (no error) for anything cycle_block would do otherwise or raise on (a type
 * it does not expect, a VCV that is not a 2x2 list of floats, an attribute missing): then
 * the Python builds the block, so every error and message is the Python's. */

/* The layout of consts (engine.run.records._CYCLE_CONSTS). */
enum {
    C_HEAD_KEYS, C_SENS_KEYS, C_GPS_KEYS, C_GPS_WEIGHT_KEYS, C_OBS_KEYS, C_LOP_KEYS,
    C_POS_KEYS, C_LSE_KEYS, C_MPP_KEYS, C_KF_KEYS, C_TEST_KEYS, C_N_KEYS, C_IN_KEYS,
    C_SYS_KEYS, C_MSG_KEYS, C_NOFIX_KEYS, C_K95, C_N_NAV, C_UTC_TEXT, C_COUNT
};

enum {
    A_N, A_TIME, A_RECORD, A_FILTER_STATUS, A_MPP, A_SOURCE, A_DATUM, A_CM_DEG, A_DT_S,
    A_SENSORS, A_RAW, A_SYSTEMS, A_STATUS, A_REFERENCE, A_STANDIN, A_HEADING_SIGMA_DEG,
    A_SPEED_SIGMA_MS, A_GPS, A_WEIGHT, A_RECEIVER_WEIGHTED, A_HDOP, A_QUALITY, A_SATS,
    A_UERE_M, A_SIGMA_M, A_MANUAL, A_FIX, A_LOPS, A_OK, A_LAT_DEG, A_LON_DEG, A_X_M, A_Y_M,
    A_DEPTH_M, A_COV, A_ELLIPSE, A_A_M, A_B_M, A_AZ_DEG, A_USES_PRIOR, A_N_USED, A_CATEGORY,
    A_S2, A_RMS_M, A_REJECTED_SLOTS, A_FIX_FAILS_TESTS, A_FIX_COV_SCALE, A_REASON, A_KF_PRED,
    A_FILTER_STATE, A_X, A_P, A_FILTER_UPDATE, A_SENSOR_UPDATE, A_LOM, A_T, A_LOWER, A_UPPER,
    A_DOF, A_VERDICT, A_LS, A_LABELS, A_MESSAGES, A_TOLIST, A_DIAGONAL, A_COUNT
};

static const char *const ATTR_NAMES[A_COUNT] = {
    "n", "time", "record", "filter_status", "mpp", "source", "datum", "cm_deg", "dt_s",
    "sensors", "raw", "systems", "status", "reference", "standin", "heading_sigma_deg",
    "speed_sigma_ms", "gps", "weight", "receiver_weighted", "hdop", "quality", "sats",
    "uere_m", "sigma_m", "manual", "fix", "lops", "ok", "lat_deg", "lon_deg", "x_m", "y_m",
    "depth_m", "cov", "ellipse", "a_m", "b_m", "az_deg", "uses_prior", "n_used", "category",
    "s2", "rms_m", "rejected_slots", "fix_fails_tests", "fix_cov_scale", "reason", "kf_pred",
    "filter_state", "x", "P", "filter_update", "sensor_update", "lom", "t", "lower", "upper",
    "dof", "verdict", "ls", "labels", "messages", "tolist", "diagonal",
};
static PyObject *ATTR[A_COUNT];

/* The attributes of the SENS, GPS, OBS and LOP lines in key order (records._SENS_GET, ...). */
static const char *const SENS_NAMES[] = {"heading_true_deg", "speed_kn", "rudder_deg",
                                         "incl_deg", "depth_m", "echo_m", "convergence_deg"};
static const char *const GPS_NAMES[] = {"lat_in_deg", "lon_in_deg", "lat_deg", "lon_deg",
                                        "x_m", "y_m", "hg_m"};
static const char *const OBS_NAMES[] = {"kind", "station", "lat_deg", "lon_deg", "value",
                                        "sigma", "sensor"};
static const char *const LOP_NAMES[] = {"system", "pattern", "read", "correction", "calc",
                                        "v_m", "w", "sigma_d", "tau", "az_deg", "used",
                                        "verdict"};
#define N_SENS 7
#define N_GPS 7
#define N_OBS 7
#define N_LOP 12
static PyObject *SENS_ATTR[N_SENS], *GPS_ATTR[N_GPS], *OBS_ATTR[N_OBS], *LOP_ATTR[N_LOP];

/* Prefixes and the str constants of cycle_block. */
enum {
    S_CYCLE, S_IN, S_SYS, S_SENS, S_GPS, S_OBS, S_LOP, S_LSE, S_NOFIX, S_KFP, S_KF, S_TEST,
    S_MPP, S_MSG, S_END, S_NL, S_WATER, S_HYBRID, S_LSE_KIND, S_FAIL, S_EPOCH, S_SENSORS,
    S_EMPTY, S_COMMA, S_FMT3, S_COUNT
};
static const char *const STR_TEXTS[S_COUNT] = {
    "CYCLE", "\n  IN", "\n  SYS", "\n  SENS", "\n  GPS", "\n  OBS", "\n  LOP", "\n  LSE",
    "\n  NOFIX", "\n  KFP", "\n  KF", "\n  TEST", "\n  MPP", "\n  MSG", "\nEND", "\n",
    "water", "hybrid", "lse", "fail", "epoch", "sensors", "", ",", ".3f",
};
static PyObject *STR[S_COUNT];
static PyObject *EMPTY_TUPLE;

static int init_cycle_names(void)
{
    for (int i = 0; i < A_COUNT; i++)
        if ((ATTR[i] = PyUnicode_InternFromString(ATTR_NAMES[i])) == NULL)
            return -1;
    for (int i = 0; i < N_SENS; i++)
        if ((SENS_ATTR[i] = PyUnicode_InternFromString(SENS_NAMES[i])) == NULL)
            return -1;
    for (int i = 0; i < N_GPS; i++)
        if ((GPS_ATTR[i] = PyUnicode_InternFromString(GPS_NAMES[i])) == NULL)
            return -1;
    for (int i = 0; i < N_OBS; i++)
        if ((OBS_ATTR[i] = PyUnicode_InternFromString(OBS_NAMES[i])) == NULL)
            return -1;
    for (int i = 0; i < N_LOP; i++)
        if ((LOP_ATTR[i] = PyUnicode_InternFromString(LOP_NAMES[i])) == NULL)
            return -1;
    for (int i = 0; i < S_COUNT; i++)
        if ((STR[i] = PyUnicode_InternFromString(STR_TEXTS[i])) == NULL)
            return -1;
    if ((EMPTY_TUPLE = PyTuple_New(0)) == NULL)
        return -1;
    return 0;
}

/* Leave the cycle to the Python (cycle_rows' callers turn this into None). */
static void *decline(void)
{
    PyErr_SetString(PyExc_LookupError, "outfmt.cycle_rows: left to the Python");
    return NULL;
}

#define GET(o, a) PyObject_GetAttr((o), ATTR[a])

/* Where build_cycle_rows puts its rows: appended to `list` (cycle_rows), or written at once
 * into `b` as render_rows would write them (cycle_text: no row objects, no second pass). */
typedef struct {
    PyObject *list;
    buf_t *b;
    PyObject *format_text, *format_value;
    int short_floats; /* floats by short_repr (else repr's routine) */
} sink_t;

/* " key=" of each key of a key tuple, built once per tuple (the key tuples of records'
 * _CYCLE_CONSTS, held here for the module's life, so a tuple's address stays its own). */
typedef struct {
    PyObject *keys;
    Py_ssize_t n;
    char *text;
    Py_ssize_t *end; /* key i is text[end[i - 1] (0 for i = 0) .. end[i]) */
    int ascii;
} keytext_t;

#define N_KEYTEXT 128
static keytext_t KEYTEXT[N_KEYTEXT];

/* The cached key texts of `keys` (an exact tuple), or NULL: a key is not an exact str or not
 * UTF-8 (the row is then written key by key, and declined where render_rows would), or the
 * table is full. */
static keytext_t *key_text(PyObject *keys)
{
    size_t h = ((uintptr_t)keys >> 4) % N_KEYTEXT;
    for (int probe = 0; probe < N_KEYTEXT; probe++, h = (h + 1) % N_KEYTEXT) {
        keytext_t *e = &KEYTEXT[h];
        if (e->keys == keys)
            return e;
        if (e->keys != NULL)
            continue;
        Py_ssize_t n = PyTuple_GET_SIZE(keys), len = 0;
        for (Py_ssize_t i = 0; i < n; i++) {
            PyObject *k = PyTuple_GET_ITEM(keys, i);
            if (!PyUnicode_CheckExact(k) || PyUnicode_AsUTF8AndSize(k, NULL) == NULL) {
                PyErr_Clear();
                return NULL;
            }
            len += PyUnicode_GET_LENGTH(k) * 4 + 2;
        }
        char *text = PyMem_Calloc((size_t)len + 16, 1); /* + 16: write_row's fixed copies */
        Py_ssize_t *end = PyMem_Malloc(sizeof(Py_ssize_t) * (size_t)(n + 1));
        if (text == NULL || end == NULL) {
            PyMem_Free(text);
            PyMem_Free(end);
            return NULL;
        }
        Py_ssize_t at = 0;
        int ascii = 1;
        for (Py_ssize_t i = 0; i < n; i++) {
            PyObject *k = PyTuple_GET_ITEM(keys, i);
            Py_ssize_t m;
            const char *u = PyUnicode_AsUTF8AndSize(k, &m);
            ascii &= PyUnicode_IS_ASCII(k) != 0;
            text[at++] = ' ';
            memcpy(text + at, u, (size_t)m);
            at += m;
            text[at++] = '=';
            end[i] = at;
        }
        e->keys = Py_NewRef(keys);
        e->n = n;
        e->text = text;
        e->end = end;
        e->ascii = ascii;
        return e;
    }
    return NULL;
}

/* A row's values on their way to the sink without a tuple: each a Python object (a new
 * reference), or, where o is NULL, a float computed or read here (the KF line, the VCVs, the
 * 95 % semi-axes), written as repr writes PyFloat_FromDouble(d) (which cycle_rows makes). */
typedef struct {
    PyObject *o;
    double d;
} val_t;

/* Write the row (prefix, keys, values) as write_rows does, the values either the items of
 * the tuple `values` or, with values NULL, vals[0..nv). 0, -1 (error) or FALLBACK. */
static int write_row_of(sink_t *s, PyObject *prefix, PyObject *keys, PyObject *values,
                        const val_t *vals, Py_ssize_t nv)
{
    buf_t *b = s->b;
    if (values != NULL) {
        if (!PyTuple_CheckExact(values))
            return FALLBACK;
        nv = PyTuple_GET_SIZE(values);
    }
    if (!PyUnicode_CheckExact(prefix) || !PyTuple_CheckExact(keys) ||
        PyTuple_GET_SIZE(keys) != nv)
        return FALLBACK;
    keytext_t *kt = key_text(keys);
    int rc = buf_put_str(b, prefix);
    if (rc)
        return rc;
    if (kt != NULL && !kt->ascii)
        b->ascii = 0;
    for (Py_ssize_t i = 0, n = nv; i < n; i++) {
        PyObject *v = values != NULL ? PyTuple_GET_ITEM(values, i) : vals[i].o;
        if (kt != NULL) {
            Py_ssize_t at = i > 0 ? kt->end[i - 1] : 0, len = kt->end[i] - at;
            if (len <= 16 && b->n + 16 <= b->cap) { /* " key=": 16 bytes copied, len kept */
                memcpy(b->p + b->n, kt->text + at, 16);
                b->n += len;
                rc = 0;
            } else {
                rc = buf_put(b, kt->text + at, len);
            }
        } else {
            PyObject *k = PyTuple_GET_ITEM(keys, i);
            if (!PyUnicode_CheckExact(k))
                return FALLBACK;
            rc = buf_putc(b, ' ');
            if (rc == 0)
                rc = buf_put_str(b, k);
            if (rc == 0)
                rc = buf_putc(b, '=');
        }
        if (rc)
            return rc;
        if (v == NULL || PyFloat_CheckExact(v)) {
            double x = v == NULL ? vals[i].d : PyFloat_AS_DOUBLE(v);
            rc = s->short_floats ? buf_put_float(b, x) : buf_put_repr(b, x);
        } else {
            rc = buf_put_value(b, v, s->format_text, s->format_value);
        }
        if (rc)
            return rc;
    }
    return 0;
}

static int write_row(sink_t *s, PyObject *prefix, PyObject *keys, PyObject *values)
{
    return write_row_of(s, prefix, keys, values, NULL, 0);
}

/* Append the row (prefix, keys, values) to the sink; steals `values`. 0 or -1 (an error set;
 * a row render_rows would leave to the Python: declined). */
static int add_row(sink_t *rows, PyObject *prefix, PyObject *keys, PyObject *values)
{
    if (values == NULL)
        return -1;
    if (rows->list == NULL) {
        int rc = write_row(rows, prefix, keys, values);
        Py_DECREF(values);
        if (rc == FALLBACK)
            decline();
        return rc == 0 ? 0 : -1;
    }
    PyObject *row = PyTuple_Pack(3, prefix, keys, values);
    Py_DECREF(values);
    if (row == NULL)
        return -1;
    int rc = PyList_Append(rows->list, row);
    Py_DECREF(row);
    return rc;
}

/* Release the references of vals[0..n). */
static void vals_clear(val_t *vals, Py_ssize_t n)
{
    for (Py_ssize_t i = 0; i < n; i++)
        Py_CLEAR(vals[i].o);
}

/* add_row of the values vals[0..n) (their references taken, the array left cleared): into
 * the sink's buffer directly, or (cycle_rows) as a tuple, each float made a float object. */
static int add_vals(sink_t *rows, PyObject *prefix, PyObject *keys, val_t *vals, Py_ssize_t n)
{
    if (rows->list == NULL) {
        int rc = write_row_of(rows, prefix, keys, NULL, vals, n);
        vals_clear(vals, n);
        if (rc == FALLBACK)
            decline();
        return rc == 0 ? 0 : -1;
    }
    PyObject *t = PyTuple_New(n);
    if (t == NULL) {
        vals_clear(vals, n);
        return -1;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *o = vals[i].o != NULL ? vals[i].o : PyFloat_FromDouble(vals[i].d);
        vals[i].o = NULL;
        if (o == NULL) {
            vals_clear(vals, n);
            Py_DECREF(t);
            return -1;
        }
        PyTuple_SET_ITEM(t, i, o);
    }
    return add_row(rows, prefix, keys, t);
}

/* A tuple of n + extra items: the attributes `names` of `o`, then `extra` empty slots. */
static PyObject *attrs_tuple(PyObject *o, PyObject *const *names,
                             Py_ssize_t n, Py_ssize_t extra)
{
    PyObject *t = PyTuple_New(n + extra);
    if (t == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *v = PyObject_GetAttr(o, names[i]);
        if (v == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, i, v);
    }
    return t;
}

/* The attributes `names` of `o` into vals[0..n) (new references). 0, or -1 (none kept). */
static int attrs_vals(PyObject *o, PyObject *const *names, Py_ssize_t n,
                      val_t *vals)
{
    for (Py_ssize_t i = 0; i < n; i++) {
        vals[i].o = PyObject_GetAttr(o, names[i]);
        vals[i].d = 0.0;
        if (vals[i].o == NULL) {
            vals_clear(vals, i);
            return -1;
        }
    }
    return 0;
}

/* vals[i] = o (a new reference, or NULL); 0, or -1 where o is NULL. */
static inline int val_set(val_t *vals, Py_ssize_t i, PyObject *o)
{
    vals[i].o = o;
    vals[i].d = 0.0;
    return o == NULL ? -1 : 0;
}

/* records._position_row: its values into v[0..] (new references, or floats; *n of them, 5 to
 * 11) and the index of its key variant (ellipse present + 2 * VCV finite). 0 or -1. */
typedef struct {
    val_t v[11];
    int n, variant;
} pos_t;

static void pos_clear(pos_t *p)
{
    vals_clear(p->v, p->n);
    p->n = 0;
}

/* The next value of p: the object o (a new reference; NULL: an error, nothing added). */
static inline int pos_obj(pos_t *p, PyObject *o)
{
    if (o == NULL)
        return -1;
    p->v[p->n].o = o;
    p->v[p->n++].d = 0.0;
    return 0;
}

/* The next value of p: the float d (written as repr writes it). */
static inline void pos_dbl(pos_t *p, double d)
{
    p->v[p->n].o = NULL;
    p->v[p->n++].d = d;
}

/* _K95 * a: the product of two exact floats as a float (float_mul: the C product), else
 * PyNumber_Multiply's object. Steals a. */
static int pos_k95(pos_t *p, PyObject *k95, PyObject *a)
{
    if (a == NULL)
        return -1;
    if (PyFloat_CheckExact(k95) && PyFloat_CheckExact(a)) {
        pos_dbl(p, PyFloat_AS_DOUBLE(k95) * PyFloat_AS_DOUBLE(a));
        Py_DECREF(a);
        return 0;
    }
    PyObject *r = PyNumber_Multiply(k95, a);
    Py_DECREF(a);
    return pos_obj(p, r);
}

static int position_row(pos_t *p, PyObject *obj, PyObject *depth, PyObject *k95)
{
    /* obj's lat_deg, lon_deg, x_m, y_m, then depth (NULL: obj.depth_m), cov, ellipse */
    static const int names[4] = {A_LAT_DEG, A_LON_DEG, A_X_M, A_Y_M};
    p->n = 0;
    p->variant = 0;
    for (int i = 0; i < 4; i++)
        if (pos_obj(p, GET(obj, names[i])) < 0)
            goto fail;
    if (pos_obj(p, depth != NULL ? Py_NewRef(depth) : GET(obj, A_DEPTH_M)) < 0)
        goto fail;
    PyObject *cov = GET(obj, A_COV), *ell = NULL;
    if (cov == NULL)
        goto fail;
    if ((ell = GET(obj, A_ELLIPSE)) == NULL) {
        Py_DECREF(cov);
        goto fail;
    }
    if (ell != Py_None) {
        if (pos_k95(p, k95, GET(ell, A_A_M)) < 0 || pos_k95(p, k95, GET(ell, A_B_M)) < 0 ||
            pos_obj(p, GET(ell, A_AZ_DEG)) < 0)
            goto fail_both;
        p->variant |= 1;
    }
    np_fields_t *fc = cov != Py_None ? np_direct(cov, 2) : NULL;
    if (fc != NULL && PyArray_DIMS(fc)[0] == 2 && PyArray_DIMS(fc)[1] == 2) {
        /* (cxx, cxy), (cyx, cyy) = cov.tolist(), read from the array */
        double c[4];
        for (int k = 0; k < 4; k++)
            c[k] = *(const double *)(PyArray_BYTES(fc) + (k >> 1) * PyArray_STRIDES(fc)[0] +
                                     (k & 1) * PyArray_STRIDES(fc)[1]);
        if (isfinite(c[0]) && isfinite(c[1]) && isfinite(c[2]) && isfinite(c[3])) {
            pos_dbl(p, c[0]);
            pos_dbl(p, c[1]);
            pos_dbl(p, c[3]);
            p->variant |= 2;
        }
    } else if (cov != Py_None) {
        PyObject *l = PyObject_CallMethodNoArgs(cov, ATTR[A_TOLIST]);
        if (l == NULL)
            goto fail_both;
        PyObject *c[4];
        int good = PyList_CheckExact(l) && PyList_GET_SIZE(l) == 2;
        for (int r = 0; good && r < 2; r++) {
            PyObject *row = PyList_GET_ITEM(l, r);
            good = PyList_CheckExact(row) && PyList_GET_SIZE(row) == 2;
            for (int k = 0; good && k < 2; k++) {
                c[2 * r + k] = PyList_GET_ITEM(row, k);
                good = PyFloat_CheckExact(c[2 * r + k]);
            }
        }
        if (!good) {
            Py_DECREF(l);
            decline();
            goto fail_both;
        }
        if (isfinite(PyFloat_AS_DOUBLE(c[0])) && isfinite(PyFloat_AS_DOUBLE(c[1])) &&
            isfinite(PyFloat_AS_DOUBLE(c[2])) && isfinite(PyFloat_AS_DOUBLE(c[3]))) {
            pos_obj(p, Py_NewRef(c[0]));
            pos_obj(p, Py_NewRef(c[1]));
            pos_obj(p, Py_NewRef(c[3]));
            p->variant |= 2;
        }
        Py_DECREF(l);
    }
    Py_DECREF(cov);
    Py_DECREF(ell);
    return 0;
fail_both:
    Py_DECREF(cov);
    Py_DECREF(ell);
fail:
    pos_clear(p);
    return -1;
}

/* sep.join(str(x) for x in items) (the items of a tuple or list). */
static PyObject *join_str(PyObject *sep, PyObject *items)
{
    if (PyTuple_CheckExact(items) && PyUnicode_GET_LENGTH(sep) == 0 &&
        PyTuple_GET_SIZE(items) <= 64) { /* the sensors' status codes: str(i) of 0..9 */
        Py_ssize_t n = PyTuple_GET_SIZE(items);
        char s[64];
        int ok = 1;
        for (Py_ssize_t i = 0; ok && i < n; i++) {
            PyObject *v = PyTuple_GET_ITEM(items, i);
            long d = PyLong_CheckExact(v) ? PyLong_AsLong(v) : -1;
            ok = d >= 0 && d <= 9;
            s[i] = (char)('0' + d);
        }
        PyErr_Clear();
        if (ok)
            return PyUnicode_FromStringAndSize(s, n);
    }
    PyObject *seq = PySequence_Fast(items, "not a sequence");
    if (seq == NULL)
        return NULL;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(seq);
    PyObject *parts = PyList_New(n);
    if (parts == NULL) {
        Py_DECREF(seq);
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *s = PyObject_Str(PySequence_Fast_GET_ITEM(seq, i));
        if (s == NULL) {
            Py_DECREF(parts);
            Py_DECREF(seq);
            return NULL;
        }
        PyList_SET_ITEM(parts, i, s);
    }
    Py_DECREF(seq);
    PyObject *r = PyUnicode_Join(sep, parts);
    Py_DECREF(parts);
    return r;
}

/* records._utc_text(t): integer formatting for an exact datetime of year 1000-9999, else
 * the Python function. */
static PyObject *utc_text(PyObject *t, PyObject *py_utc_text)
{
    if (PyDateTimeAPI != NULL && PyDateTime_CheckExact(t)) {
        int y = PyDateTime_GET_YEAR(t);
        if (y >= 1000 && y <= 9999) { /* "%04d-%02d-%02dT%02d:%02d:%02dZ", written out */
            const int f[5] = {PyDateTime_GET_MONTH(t), PyDateTime_GET_DAY(t),
                              PyDateTime_DATE_GET_HOUR(t), PyDateTime_DATE_GET_MINUTE(t),
                              PyDateTime_DATE_GET_SECOND(t)};
            static const char sep[5] = {'-', '-', 'T', ':', ':'};
            PyObject *u = PyUnicode_New(20, 127);
            if (u == NULL)
                return NULL;
            char *s = (char *)PyUnicode_DATA(u);
            memcpy(s, DIGITS2 + 2 * (y / 100), 2);
            memcpy(s + 2, DIGITS2 + 2 * (y % 100), 2);
            for (int k = 0; k < 5; k++) { /* each 0..99 (a datetime's own ranges) */
                s[4 + 3 * k] = sep[k];
                memcpy(s + 5 + 3 * k, DIGITS2 + 2 * f[k], 2);
            }
            s[19] = 'Z';
            return u;
        }
    }
    return PyObject_CallOneArg(py_utc_text, t);
}

/* ",".join(map("{:.3f}".format, values.tolist())) of the TEST line. */
static PyObject *ls_text_slow(PyObject *ls_t);

static PyObject *ls_text(PyObject *ls_t)
{
    np_fields_t *f = np_direct(ls_t, 1);
    if (f == NULL)
        return ls_text_slow(ls_t);
    Py_ssize_t n = PyArray_DIMS(f)[0], st = PyArray_STRIDES(f)[0];
    char stack_buf[512];
    buf_t b = {stack_buf, 0, (Py_ssize_t)sizeof stack_buf, 0, 1};
    PyObject *r = NULL;
    for (Py_ssize_t i = 0; i < n; i++) {
        double x = *(const double *)(PyArray_BYTES(f) + i * st);
        if (buf_reserve(&b, 33) < 0)
            goto done;
        if (i > 0)
            b.p[b.n++] = ',';
        int k = short_state == 1 ? fixed3(x, b.p + b.n) : 0;
        if (k > 0) {
            b.n += k;
            continue;
        }
        char *c = PyOS_double_to_string(x, 'f', 3, 0, NULL);
        if (c == NULL)
            goto done;
        int rc = buf_put(&b, c, (Py_ssize_t)strlen(c));
        PyMem_Free(c);
        if (rc < 0)
            goto done;
    }
    if ((r = PyUnicode_New(b.n, 127)) != NULL)
        memcpy(PyUnicode_DATA(r), b.p, (size_t)b.n);
done:
    if (b.heap)
        PyMem_Free(b.p);
    return r;
}

/* ls_text by the array's tolist (an array np_direct does not read). */
static PyObject *ls_text_slow(PyObject *ls_t)
{
    PyObject *l = PyObject_CallMethodNoArgs(ls_t, ATTR[A_TOLIST]);
    if (l == NULL)
        return NULL;
    if (!PyList_CheckExact(l)) {
        Py_DECREF(l);
        return decline();
    }
    Py_ssize_t n = PyList_GET_SIZE(l);
    PyObject *parts = PyList_New(n);
    if (parts == NULL) {
        Py_DECREF(l);
        return NULL;
    }
    for (Py_ssize_t i = 0; i < n; i++) {
        PyObject *v = PyList_GET_ITEM(l, i), *s;
        if (PyFloat_CheckExact(v)) {
            char *c = PyOS_double_to_string(PyFloat_AS_DOUBLE(v), 'f', 3, 0, NULL);
            if (c == NULL) {
                s = NULL;
            } else {
                s = PyUnicode_FromString(c);
                PyMem_Free(c);
            }
        } else {
            s = PyObject_Format(v, STR[S_FMT3]);
        }
        if (s == NULL) {
            Py_DECREF(parts);
            Py_DECREF(l);
            return NULL;
        }
        PyList_SET_ITEM(parts, i, s);
    }
    Py_DECREF(l);
    PyObject *r = PyUnicode_Join(STR[S_COMMA], parts);
    Py_DECREF(parts);
    return r;
}

/* `x[:n].tolist()` as a list (exact), or NULL. */
static PyObject *head_list(PyObject *x, PyObject *n_nav)
{
    PyObject *sl = PySlice_New(NULL, n_nav, NULL);
    if (sl == NULL)
        return NULL;
    PyObject *part = PyObject_GetItem(x, sl);
    Py_DECREF(sl);
    if (part == NULL)
        return NULL;
    PyObject *l = PyObject_CallMethodNoArgs(part, ATTR[A_TOLIST]);
    Py_DECREF(part);
    if (l != NULL && !PyList_CheckExact(l)) {
        Py_DECREF(l);
        return decline();
    }
    return l;
}

/* The KF line's values: the states, then the standard deviations of P's diagonal. Read from
 * the arrays: into kv[0..*kn) as floats (at most KF_VALS of them), NULL returned; else a
 * tuple (*kn -1), or NULL with an error set (*kn -1). */
#define KF_VALS 64
static PyObject *kf_values(PyObject *fs, PyObject *n_nav, val_t *kv, Py_ssize_t *kn)
{
    *kn = -1;
    PyObject *x = NULL, *xl = NULL, *P = NULL, *d = NULL, *dl = NULL, *t = NULL;
    if ((x = GET(fs, A_X)) == NULL)
        goto done;
    Py_ssize_t nn = PyLong_CheckExact(n_nav) ? PyLong_AsSsize_t(n_nav) : -1;
    if (nn == -1 && PyErr_Occurred())
        goto done;
    np_fields_t *fx = nn >= 0 ? np_direct(x, 1) : NULL, *fp = NULL;
    if (fx != NULL) {
        if ((P = GET(fs, A_P)) == NULL)
            goto done;
        fp = np_direct(P, 2);
    }
    if (fp != NULL) { /* x[:n].tolist() and P.diagonal()[:n].tolist() read from the arrays */
        Py_ssize_t nx = PyArray_DIMS(fx)[0] < nn ? PyArray_DIMS(fx)[0] : nn;
        Py_ssize_t nd = PyArray_DIMS(fp)[0] < PyArray_DIMS(fp)[1] ? PyArray_DIMS(fp)[0]
                                                               : PyArray_DIMS(fp)[1];
        nd = nd < nn ? nd : nn;
        Py_ssize_t sx = PyArray_STRIDES(fx)[0], sd = PyArray_STRIDES(fp)[0] + PyArray_STRIDES(fp)[1];
        if (nx + nd <= KF_VALS) { /* the floats themselves, no objects */
            for (Py_ssize_t i = 0; i < nx + nd; i++) {
                double v = i < nx ? *(const double *)(PyArray_BYTES(fx) + i * sx)
                                  : *(const double *)(PyArray_BYTES(fp) + (i - nx) * sd);
                if (i >= nx) /* records: sqrt(v) if v > 0.0 else (v if v != v else 0.0) */
                    v = v > 0.0 ? sqrt(v) : (v != v ? v : 0.0);
                kv[i].o = NULL;
                kv[i].d = v;
            }
            *kn = nx + nd;
            goto done;
        }
        if ((t = PyTuple_New(nx + nd)) == NULL)
            goto done;
        for (Py_ssize_t i = 0; i < nx + nd; i++) {
            double v = i < nx ? *(const double *)(PyArray_BYTES(fx) + i * sx)
                              : *(const double *)(PyArray_BYTES(fp) + (i - nx) * sd);
            if (i >= nx) /* records: sqrt(v) if v > 0.0 else (v if v != v else 0.0) */
                v = v > 0.0 ? sqrt(v) : (v != v ? v : 0.0);
            PyObject *o = PyFloat_FromDouble(v);
            if (o == NULL) {
                Py_CLEAR(t);
                goto done;
            }
            PyTuple_SET_ITEM(t, i, o);
        }
        goto done;
    }
    Py_CLEAR(P);
    if ((xl = head_list(x, n_nav)) == NULL)
        goto done;
    if ((P = GET(fs, A_P)) == NULL ||
        (d = PyObject_CallMethodNoArgs(P, ATTR[A_DIAGONAL])) == NULL ||
        (dl = head_list(d, n_nav)) == NULL)
        goto done;
    Py_ssize_t nx = PyList_GET_SIZE(xl), nd = PyList_GET_SIZE(dl);
    if ((t = PyTuple_New(nx + nd)) == NULL)
        goto done;
    for (Py_ssize_t i = 0; i < nx; i++)
        PyTuple_SET_ITEM(t, i, Py_NewRef(PyList_GET_ITEM(xl, i)));
    for (Py_ssize_t i = 0; i < nd; i++) {
        PyObject *v = PyList_GET_ITEM(dl, i), *s;
        if (!PyFloat_CheckExact(v)) {
            Py_CLEAR(t);
            decline();
            goto done;
        }
        double var = PyFloat_AS_DOUBLE(v);
        /* records: sqrt(v) if v > 0.0 else (v if v != v else 0.0) */
        if (var > 0.0)
            s = PyFloat_FromDouble(sqrt(var));
        else
            s = var != var ? Py_NewRef(v) : PyFloat_FromDouble(0.0);
        if (s == NULL) {
            Py_CLEAR(t);
            goto done;
        }
        PyTuple_SET_ITEM(t, nx + i, s);
    }
done:
    Py_XDECREF(x);
    Py_XDECREF(xl);
    Py_XDECREF(P);
    Py_XDECREF(d);
    Py_XDECREF(dl);
    return t;
}

/* The TEST line of one update. */
static int add_test(sink_t *rows, PyObject *keys, PyObject *u, PyObject *kind)
{
    static const int lom_names[5] = {A_T, A_LOWER, A_UPPER, A_DOF, A_VERDICT};
    PyObject *lom = NULL, *ls = NULL, *ls_t = NULL, *labels = NULL;
    val_t t[8];
    Py_ssize_t n = 0;
    if ((lom = GET(u, A_LOM)) == NULL)
        goto fail;
    for (int i = 0; i < 5; i++, n++)
        if (val_set(t, n, GET(lom, lom_names[i])) < 0)
            goto fail;
    if ((ls = GET(u, A_LS)) == NULL || (ls_t = GET(ls, A_T)) == NULL)
        goto fail;
    if (val_set(t, n, ls_text(ls_t)) < 0)
        goto fail;
    n++;
    val_set(t, n++, Py_NewRef(kind));
    if ((labels = GET(u, A_LABELS)) == NULL)
        goto fail;
    if (val_set(t, n, PyUnicode_Join(STR[S_COMMA], labels)) < 0)
        goto fail;
    n++;
    Py_DECREF(lom);
    Py_DECREF(ls);
    Py_DECREF(ls_t);
    Py_DECREF(labels);
    return add_vals(rows, STR[S_TEST], keys, t, n);
fail:
    vals_clear(t, n);
    Py_XDECREF(lom);
    Py_XDECREF(ls);
    Py_XDECREF(ls_t);
    Py_XDECREF(labels);
    return -1;
}

/* Append a row per item of the iterable `items`: (prefix, keys, attrs of the item), or with
 * names == NULL (prefix, keys, (item,)). */
#define EACH_VALS 16
static int add_each(sink_t *rows, PyObject *items, PyObject *prefix, PyObject *keys,
                    PyObject *const *names, Py_ssize_t n)
{
    PyObject *it = PyObject_GetIter(items), *o;
    if (it == NULL)
        return -1;
    while ((o = PyIter_Next(it)) != NULL) {
        int rc;
        if (names == NULL) {
            val_t v = {o, 0.0}; /* takes o */
            rc = add_vals(rows, prefix, keys, &v, 1);
        } else if (n <= EACH_VALS) {
            val_t v[EACH_VALS];
            rc = attrs_vals(o, names, n, v);
            Py_DECREF(o);
            if (rc == 0)
                rc = add_vals(rows, prefix, keys, v, n);
        } else {
            PyObject *v = attrs_tuple(o, names, n, 0);
            Py_DECREF(o);
            rc = add_row(rows, prefix, keys, v);
        }
        if (rc < 0) {
            Py_DECREF(it);
            return -1;
        }
    }
    Py_DECREF(it);
    return PyErr_Occurred() ? -1 : 0;
}

/* Is obj.<attr> true? 1, 0 or -1. */
static int attr_true(PyObject *obj, int attr)
{
    PyObject *v = GET(obj, attr);
    if (v == NULL)
        return -1;
    int r = PyObject_IsTrue(v);
    Py_DECREF(v);
    return r;
}

static int build_cycle_rows(sink_t *rows, PyObject *r, PyObject *consts)
{
    if (!PyTuple_CheckExact(consts) || PyTuple_GET_SIZE(consts) != C_COUNT) {
        decline();
        return -1;
    }
    if (np_layout < 0 && np_ready() < 0) /* numpy's arrays read directly once checked */
        return -1;
    PyObject *const *c = &PyTuple_GET_ITEM(consts, 0);
    PyObject *mpp = NULL, *s = NULL, *o = NULL,
             *n_obj = NULL;
    pos_t pos = {.n = 0};
    int rc;
    if ((mpp = GET(r, A_MPP)) == NULL)
        goto fail;

    /* CYCLE n t record filter source datum cm dt */
    {
        static const int head[8] = {A_N, A_TIME, A_RECORD, A_FILTER_STATUS, -1, A_DATUM,
                                    A_CM_DEG, A_DT_S};
        val_t hv[8];
        for (int i = 0; i < 8; i++) {
            PyObject *x = head[i] < 0 ? GET(mpp, A_SOURCE) : GET(r, head[i]);
            if (x != NULL && i == 1) {
                PyObject *t = utc_text(x, c[C_UTC_TEXT]);
                Py_DECREF(x);
                x = t;
            }
            if (val_set(hv, i, x) < 0) {
                vals_clear(hv, i);
                goto fail;
            }
        }
        n_obj = Py_NewRef(hv[0].o);
        if (add_vals(rows, STR[S_CYCLE], c[C_HEAD_KEYS], hv, 8) < 0)
            goto fail;
    }

    /* IN, SYS, SENS */
    if ((s = GET(r, A_SENSORS)) == NULL)
        goto fail;
    {
        PyObject *ref = GET(s, A_REFERENCE);
        if (ref == NULL)
            goto fail;
        int other = PyObject_RichCompareBool(ref, STR[S_WATER], Py_NE), standin = 0;
        if (other > 0 && (standin = attr_true(s, A_STANDIN)) < 0)
            other = -1;
        if (other < 0) {
            Py_DECREF(ref);
            goto fail;
        }
        val_t sens[N_SENS + 3];
        Py_ssize_t ns = N_SENS;
        rc = attrs_vals(s, SENS_ATTR, N_SENS, sens);
        if (rc == 0 && other) {
            val_set(sens, ns++, Py_NewRef(ref));
            if (standin) {
                PyObject *hs = GET(s, A_HEADING_SIGMA_DEG), *ss = hs ? GET(s, A_SPEED_SIGMA_MS)
                                                                     : NULL;
                if (ss == NULL) {
                    Py_XDECREF(hs);
                    vals_clear(sens, ns);
                    rc = -1;
                } else {
                    val_set(sens, ns++, hs);
                    val_set(sens, ns++, ss);
                }
            }
        }
        Py_DECREF(ref);
        if (rc < 0)
            goto fail;
        val_t one[2];
        if (val_set(one, 0, GET(r, A_RAW)) < 0 ||
            add_vals(rows, STR[S_IN], c[C_IN_KEYS], one, 1) < 0) {
            vals_clear(sens, ns);
            goto fail;
        }
        PyObject *systems = GET(r, A_SYSTEMS), *status = NULL, *st = NULL;
        if (systems != NULL && (status = GET(s, A_STATUS)) != NULL)
            st = join_str(STR[S_EMPTY], status);
        Py_XDECREF(status);
        if (st == NULL) {
            Py_XDECREF(systems);
            rc = -1;
        } else {
            val_set(one, 0, systems);
            val_set(one, 1, st);
            rc = add_vals(rows, STR[S_SYS], c[C_SYS_KEYS], one, 2);
        }
        if (rc < 0) {
            vals_clear(sens, ns);
            goto fail;
        }
        PyObject *keys = PyTuple_GET_ITEM(c[C_SENS_KEYS], other ? (standin ? 2 : 1) : 0);
        if (add_vals(rows, STR[S_SENS], keys, sens, ns) < 0)
            goto fail;
    }

    /* GPS */
    if ((o = GET(r, A_GPS)) == NULL)
        goto fail;
    if (o != Py_None) {
        PyObject *w = GET(o, A_WEIGHT);
        if (w == NULL)
            goto fail;
        int weighted = w != Py_None ? attr_true(w, A_RECEIVER_WEIGHTED) : 0;
        if (weighted < 0) {
            Py_DECREF(w);
            goto fail;
        }
        val_t g[N_GPS + 5];
        Py_ssize_t ng = N_GPS;
        rc = attrs_vals(o, GPS_ATTR, N_GPS, g);
        if (rc == 0 && weighted) {
            static const int wn[5] = {A_HDOP, A_QUALITY, A_SATS, A_UERE_M, A_SIGMA_M};
            for (int i = 0; i < 5; i++, ng++) {
                if (val_set(g, ng, GET(w, wn[i])) < 0) {
                    vals_clear(g, ng);
                    rc = -1;
                    break;
                }
            }
        }
        Py_DECREF(w);
        if (rc < 0 ||
            add_vals(rows, STR[S_GPS], c[weighted ? C_GPS_WEIGHT_KEYS : C_GPS_KEYS], g, ng) < 0)
            goto fail;
    }
    Py_CLEAR(o);

    /* OBS */
    if ((o = GET(r, A_MANUAL)) == NULL ||
        add_each(rows, o, STR[S_OBS], c[C_OBS_KEYS], OBS_ATTR, N_OBS) < 0)
        goto fail;
    Py_CLEAR(o);

    /* LOP, LSE / NOFIX */
    if ((o = GET(r, A_FIX)) == NULL)
        goto fail;
    if (o != Py_None) {
        PyObject *lops = GET(o, A_LOPS);
        if (lops == NULL)
            goto fail;
        rc = add_each(rows, lops, STR[S_LOP], c[C_LOP_KEYS], LOP_ATTR, N_LOP);
        Py_DECREF(lops);
        if (rc < 0)
            goto fail;
        int ok = attr_true(o, A_OK);
        if (ok < 0)
            goto fail;
        if (ok) {
            PyObject *zero = PyFloat_FromDouble(0.0);
            if (zero == NULL)
                goto fail;
            rc = position_row(&pos, o, zero, c[C_K95]);
            Py_DECREF(zero);
            if (rc < 0)
                goto fail;
            PyObject *head[5] = {NULL, NULL, NULL, NULL, NULL}, *rej = NULL, *rej_text = NULL,
                     *scale = NULL;
            int prior = attr_true(o, A_USES_PRIOR), variant = pos.variant, fails = 0;
            static const int hn[4] = {A_N_USED, A_CATEGORY, A_S2, A_RMS_M};
            rc = prior < 0 ? -1 : 0;
            if (rc == 0)
                head[0] = Py_NewRef(STR[prior ? S_HYBRID : S_LSE_KIND]);
            for (int i = 0; rc == 0 && i < 4; i++)
                if ((head[i + 1] = GET(o, hn[i])) == NULL)
                    rc = -1;
            if (rc == 0 && (rej = GET(o, A_REJECTED_SLOTS)) == NULL)
                rc = -1;
            int has_rej = rc == 0 ? PyObject_IsTrue(rej) : 0;
            if (has_rej < 0)
                rc = -1;
            if (rc == 0 && has_rej && (rej_text = join_str(STR[S_COMMA], rej)) == NULL)
                rc = -1;
            if (rc == 0 && (fails = attr_true(r, A_FIX_FAILS_TESTS)) < 0)
                rc = -1;
            if (rc == 0 && fails && (scale = GET(r, A_FIX_COV_SCALE)) == NULL)
                rc = -1;
            if (rc == 0) { /* head, the position's values, rejected, fail and scale */
                val_t lv[5 + 11 + 3];
                Py_ssize_t k = 0;
                for (int i = 0; i < 5; i++) {
                    lv[k].o = head[i];
                    lv[k++].d = 0.0;
                    head[i] = NULL;
                }
                for (int i = 0; i < pos.n; i++) {
                    lv[k++] = pos.v[i];
                    pos.v[i].o = NULL;
                }
                pos.n = 0;
                if (has_rej) {
                    lv[k].o = rej_text;
                    lv[k++].d = 0.0;
                    rej_text = NULL;
                }
                if (fails) {
                    lv[k].o = Py_NewRef(STR[S_FAIL]);
                    lv[k++].d = 0.0;
                    lv[k].o = scale;
                    lv[k++].d = 0.0;
                    scale = NULL;
                }
                int idx = variant | (has_rej ? 4 : 0) | (fails ? 8 : 0);
                rc = add_vals(rows, STR[S_LSE], PyTuple_GET_ITEM(c[C_LSE_KEYS], idx), lv, k);
            }
            for (int i = 0; i < 5; i++)
                Py_XDECREF(head[i]);
            Py_XDECREF(rej);
            Py_XDECREF(rej_text);
            Py_XDECREF(scale);
            pos_clear(&pos);
            if (rc < 0)
                goto fail;
        } else {
            val_t reason;
            if (val_set(&reason, 0, GET(o, A_REASON)) < 0 ||
                add_vals(rows, STR[S_NOFIX], c[C_NOFIX_KEYS], &reason, 1) < 0)
                goto fail;
        }
    }
    Py_CLEAR(o);

    /* KFP */
    if ((o = GET(r, A_KF_PRED)) == NULL)
        goto fail;
    if (o != Py_None) {
        if (position_row(&pos, o, NULL, c[C_K95]) < 0)
            goto fail;
        int variant = pos.variant, n = pos.n;
        pos.n = 0; /* add_vals takes the values */
        rc = add_vals(rows, STR[S_KFP], PyTuple_GET_ITEM(c[C_POS_KEYS], variant), pos.v, n);
        if (rc < 0)
            goto fail;
    }
    Py_CLEAR(o);

    /* KF */
    if ((o = GET(r, A_FILTER_STATE)) == NULL)
        goto fail;
    if (o != Py_None) {
        val_t kv[KF_VALS];
        Py_ssize_t kn;
        PyObject *t = kf_values(o, c[C_N_NAV], kv, &kn);
        rc = kn >= 0 ? add_vals(rows, STR[S_KF], c[C_KF_KEYS], kv, kn)
                     : add_row(rows, STR[S_KF], c[C_KF_KEYS], t);
        if (rc < 0)
            goto fail;
    }
    Py_CLEAR(o);

    /* TEST: the epoch's update, then the sensors' (records.updates) */
    if ((o = GET(r, A_FILTER_UPDATE)) == NULL)
        goto fail;
    if (o != Py_None && add_test(rows, c[C_TEST_KEYS], o, STR[S_EPOCH]) < 0)
        goto fail;
    Py_CLEAR(o);
    if ((o = GET(r, A_SENSOR_UPDATE)) == NULL)
        goto fail;
    if (o != Py_None && add_test(rows, c[C_TEST_KEYS], o, STR[S_SENSORS]) < 0)
        goto fail;
    Py_CLEAR(o);

    /* MPP */
    if (position_row(&pos, mpp, NULL, c[C_K95]) < 0)
        goto fail;
    {
        PyObject *src = GET(mpp, A_SOURCE);
        if (src == NULL)
            goto fail;
        val_t mv[1 + 11]; /* (mpp.source,) + pos */
        mv[0].o = src;
        mv[0].d = 0.0;
        for (int i = 0; i < pos.n; i++)
            mv[1 + i] = pos.v[i];
        int variant = pos.variant, n = pos.n;
        pos.n = 0; /* add_vals takes the values */
        rc = add_vals(rows, STR[S_MPP], PyTuple_GET_ITEM(c[C_MPP_KEYS], variant), mv, 1 + n);
        if (rc < 0)
            goto fail;
    }

    /* MSG */
    if ((o = GET(r, A_MESSAGES)) == NULL ||
        add_each(rows, o, STR[S_MSG], c[C_MSG_KEYS], NULL, 0) < 0)
        goto fail;
    Py_CLEAR(o);

    /* END n, and the final newline (OutLogWriter.write_cycle) */
    {
        val_t end = {n_obj, 0.0}; /* takes n_obj */
        n_obj = NULL;
        if (add_vals(rows, STR[S_END], c[C_N_KEYS], &end, 1) < 0 ||
            add_vals(rows, STR[S_NL], EMPTY_TUPLE, &end, 0) < 0)
            goto fail;
    }
    Py_DECREF(mpp);
    Py_DECREF(s);
    return 0;

fail:
    Py_XDECREF(n_obj);
    pos_clear(&pos);
    Py_XDECREF(o);
    Py_XDECREF(s);
    Py_XDECREF(mpp);
    return -1;
}

/* NULL with an Exception set -> None (the Python builds the block and meets the error
 * itself); anything else (KeyboardInterrupt, ...) propagates. */
static PyObject *declined(void)
{
    if (PyErr_ExceptionMatches(PyExc_Exception)) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    return NULL;
}

static PyObject *cycle_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "cycle_rows(r, consts) takes 2 arguments");
        return NULL;
    }
    sink_t sink = {PyList_New(0), NULL, NULL, NULL, 0};
    if (sink.list == NULL)
        return NULL;
    if (build_cycle_rows(&sink, args[0], args[1]) < 0) {
        Py_DECREF(sink.list);
        return declined();
    }
    return sink.list;
}

static PyObject *cycle_text(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError,
                        "cycle_text(r, consts, dumps, format_text, format_value) takes 5 "
                        "arguments");
        return NULL;
    }
    char stack_buf[8192];
    buf_t b = {stack_buf, 0, (Py_ssize_t)sizeof stack_buf, 0, 1};
    sink_t sink = {NULL, &b, args[3], args[4], args[2] != Py_None && short_ok()};
    PyObject *text = NULL;
    if (build_cycle_rows(&sink, args[0], args[1]) < 0)
        text = declined();
    else if (b.ascii && (text = PyUnicode_New(b.n, 127)) != NULL)
        memcpy(PyUnicode_DATA(text), b.p, (size_t)b.n);
    else if (!b.ascii)
        text = PyUnicode_DecodeUTF8(b.p, b.n, "strict");
    if (b.heap)
        PyMem_Free(b.p);
    return text;
}

/* ------------------------------------------------------------------------- the cycle's commit */

/* cycle_writer(consts, dumps, format_text, format_value) -> write(r, fd): cycle_text bound to
 * its constant arguments (a builtin function whose self is their tuple: no Python frame per
 * cycle), writing the block's bytes itself to the file descriptor `fd` with write(2) (the
 * whole buffer, a partial write continued, EINTR retried after the signal handlers ran, the
 * GIL released around each call, as FileIO.write does): the UTF-8 bytes a TextIOWrapper
 * (utf-8, newline "\n") would write for cycle_text's str, without making that str. Returns the
 * number of bytes written, None where cycle_text declines (nothing written), OSError (errno)
 * when the operating system refuses the write (engine.io.outlog.OutLogWriter.write_direct
 * names the file). */
static int write_all(int fd, const char *p, Py_ssize_t n)
{
    while (n > 0) {
        Py_ssize_t w;
        Py_BEGIN_ALLOW_THREADS
        w = (Py_ssize_t)write(fd, p, (size_t)n);
        Py_END_ALLOW_THREADS
        if (w < 0) {
            if (errno == EINTR) {
                if (PyErr_CheckSignals() < 0)
                    return -1;
                continue;
            }
            PyErr_SetFromErrno(PyExc_OSError);
            return -1;
        }
        p += w;
        n -= w;
    }
    return 0;
}

static PyObject *cycle_write(PyObject *bound, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "write(r, fd) takes 2 arguments");
        return NULL;
    }
    int overflow = 0;
    long fd = PyLong_AsLongAndOverflow(args[1], &overflow);
    if (fd == -1 && PyErr_Occurred())
        return NULL;
    if (overflow || fd < 0 || fd > INT_MAX) {
        PyErr_SetString(PyExc_ValueError, "write(r, fd): fd is not a file descriptor");
        return NULL;
    }
    PyObject *const *c = &PyTuple_GET_ITEM(bound, 0);
    char stack_buf[8192];
    buf_t b = {stack_buf, 0, (Py_ssize_t)sizeof stack_buf, 0, 1};
    sink_t sink = {NULL, &b, c[2], c[3], c[1] != Py_None && short_ok()};
    PyObject *res;
    if (build_cycle_rows(&sink, args[0], c[0]) < 0)
        res = declined();
    else if (write_all((int)fd, b.p, b.n) < 0)
        res = NULL;
    else
        res = PyLong_FromSsize_t(b.n);
    if (b.heap)
        PyMem_Free(b.p);
    return res;
}

static PyMethodDef CYCLE_WRITE_DEF = {
    "write_cycle", (PyCFunction)(void (*)(void))cycle_write, METH_FASTCALL,
    "write(r, fd) -> int | None: the .OUT block of r (cycle_text's text, UTF-8) written to fd;\n"
    "its length in bytes, or None (nothing written) where the Python must build it."};

static PyObject *cycle_writer(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError,
                        "cycle_writer(consts, dumps, format_text, format_value) takes 4 "
                        "arguments");
        return NULL;
    }
    /* its __module__ is this module's name (as for the module's own functions), so that a
     * profile names it engine.native.outfmt.write_cycle: bench_engine counts kernel time so */
    PyObject *name = PyModule_GetNameObject(self);
    if (name == NULL)
        return NULL;
    PyObject *bound = PyTuple_New(4);
    if (bound == NULL) {
        Py_DECREF(name);
        return NULL;
    }
    for (int i = 0; i < 4; i++)
        PyTuple_SET_ITEM(bound, i, Py_NewRef(args[i]));
    PyObject *f = PyCFunction_NewEx(&CYCLE_WRITE_DEF, bound, name);
    Py_DECREF(bound);
    Py_DECREF(name);
    return f;
}

/* freeze_result(fix, phi, u1, u2): engine.run.cycle._freeze_result's twin, the same arrays
 * made read-only in the same order (fix.cov, fix.ellipse.eigenvectors, fix.raw_lops' A, omc_m,
 * Cl and x_ref, phi, then each update's innovation, S, K, ls.l_inv and ls.w; a None skipped
 * where the Python skips it). An exact numpy.ndarray has its WRITEABLE flag cleared here, what
 * setflags(write=False) does once uvn_numpy.h checked that at first use (and only without
 * NPY_ARRAY_WARN_ON_WRITE, which setflags clears too); anything else gets the call
 * a.setflags(write=False) itself. Returns True, or None (nothing done: numpy not ready) for the
 * Python to do it; an error raised on the way is the one the Python raises at that point. */
enum { F_COV, F_ELLIPSE, F_EIGENVECTORS, F_RAW_LOPS, F_A, F_OMC_M, F_CL, F_X_REF, F_INNOVATION,
       F_S, F_K, F_LS, F_L_INV, F_W, F_SETFLAGS, F_WRITE, F_COUNT };
static const char *const FREEZE_NAMES[F_COUNT] = {
    "cov", "ellipse", "eigenvectors", "raw_lops", "A", "omc_m", "Cl", "x_ref", "innovation",
    "S", "K", "ls", "l_inv", "w", "setflags", "write"};
static PyObject *FREEZE_ATTR[F_COUNT];
static PyObject *WRITE_KWNAMES; /* ("write",) */

static int freeze_names(void)
{
    for (int i = 0; i < F_COUNT; i++)
        if ((FREEZE_ATTR[i] = PyUnicode_InternFromString(FREEZE_NAMES[i])) == NULL)
            return -1;
    return (WRITE_KWNAMES = PyTuple_Pack(1, FREEZE_ATTR[F_WRITE])) == NULL ? -1 : 0;
}

/* a.setflags(write=False): 0, or -1 (exception set). An exact ndarray by numpy's
 * PyArray_CLEARFLAGS, anything else by its setflags method. */
static int freeze_array(PyObject *a)
{
    if (np_layout == 1 && (PyObject *)Py_TYPE(a) == np_ndarray) {
        PyArray_CLEARFLAGS((PyArrayObject *)a, NPY_ARRAY_WRITEABLE);
        return 0;
    }
    PyObject *call[2] = {a, Py_False};
    PyObject *r = PyObject_VectorcallMethod(FREEZE_ATTR[F_SETFLAGS], call,
                                            1 | PY_VECTORCALL_ARGUMENTS_OFFSET, WRITE_KWNAMES);
    if (r == NULL)
        return -1;
    Py_DECREF(r);
    return 0;
}

/* getattr(o, FREEZE_ATTR[i]) frozen: 0, or -1. */
static int freeze_attr(PyObject *o, int i)
{
    PyObject *a = PyObject_GetAttr(o, FREEZE_ATTR[i]);
    if (a == NULL)
        return -1;
    int rc = freeze_array(a);
    Py_DECREF(a);
    return rc;
}

static PyObject *freeze_result(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "freeze_result(fix, phi, u1, u2) takes 4 arguments");
        return NULL;
    }
    if (np_layout < 0 && np_ready() < 0) {
        if (!PyErr_ExceptionMatches(PyExc_Exception))
            return NULL;
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    PyObject *fix = args[0], *o = NULL, *ls = NULL;
    if (fix != Py_None) {
        if (freeze_attr(fix, F_COV) < 0 || (o = PyObject_GetAttr(fix, FREEZE_ATTR[F_ELLIPSE])) == NULL)
            return NULL;
        int rc = o == Py_None ? 0 : freeze_attr(o, F_EIGENVECTORS);
        Py_DECREF(o);
        if (rc < 0 || (o = PyObject_GetAttr(fix, FREEZE_ATTR[F_RAW_LOPS])) == NULL)
            return NULL;
        if (o != Py_None) { /* A, omc_m, Cl, x_ref: read all four, then frozen (the tuple) */
            PyObject *arr[4] = {NULL, NULL, NULL, NULL};
            for (int k = 0; k < 4 && rc == 0; k++)
                if ((arr[k] = PyObject_GetAttr(o, FREEZE_ATTR[F_A + k])) == NULL)
                    rc = -1;
            for (int k = 0; k < 4 && rc == 0; k++)
                rc = freeze_array(arr[k]);
            for (int k = 0; k < 4; k++)
                Py_XDECREF(arr[k]);
        }
        Py_DECREF(o);
        if (rc < 0)
            return NULL;
    }
    if (args[1] != Py_None && freeze_array(args[1]) < 0)
        return NULL;
    for (int j = 2; j < 4; j++) {
        PyObject *u = args[j];
        if (u == Py_None)
            continue;
        /* (u.innovation, u.S, u.K, u.ls.l_inv, u.ls.w): read all five, then frozen */
        PyObject *arr[5] = {NULL, NULL, NULL, NULL, NULL};
        int rc = 0;
        for (int k = 0; k < 3 && rc == 0; k++)
            if ((arr[k] = PyObject_GetAttr(u, FREEZE_ATTR[F_INNOVATION + k])) == NULL)
                rc = -1;
        if (rc == 0 && (ls = PyObject_GetAttr(u, FREEZE_ATTR[F_LS])) == NULL)
            rc = -1;
        if (rc == 0 && (arr[3] = PyObject_GetAttr(ls, FREEZE_ATTR[F_L_INV])) == NULL)
            rc = -1;
        if (rc == 0 && (arr[4] = PyObject_GetAttr(ls, FREEZE_ATTR[F_W])) == NULL)
            rc = -1;
        Py_XDECREF(ls);
        ls = NULL;
        for (int k = 0; k < 5 && rc == 0; k++)
            rc = freeze_array(arr[k]);
        for (int k = 0; k < 5; k++)
            Py_XDECREF(arr[k]);
        if (rc < 0)
            return NULL;
    }
    Py_RETURN_TRUE;
}

/* ------------------------------------------------------------------------- test hooks */

static PyObject *float_repr(PyObject *self, PyObject *arg)
{
    double x = PyFloat_AsDouble(arg);
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    char *s = PyOS_double_to_string(x, 'r', 0, Py_DTSF_ADD_DOT_0, NULL);
    if (s == NULL)
        return NULL;
    PyObject *r = PyUnicode_FromString(s);
    PyMem_Free(s);
    return r;
}

static PyObject *short_checked(PyObject *self, PyObject *unused)
{
    return PyBool_FromLong(short_ok());
}

static PyObject *fixed3_float(PyObject *self, PyObject *arg)
{
    double x = PyFloat_AsDouble(arg);
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    char s[48];
    int n = fixed3(x, s);
    if (n == 0)
        Py_RETURN_NONE;
    return PyUnicode_FromStringAndSize(s, n);
}

static PyObject *short_float(PyObject *self, PyObject *arg)
{
    double x = PyFloat_AsDouble(arg);
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    char s[48];
    int n = short_repr(x, s);
    if (n == 0)
        Py_RETURN_NONE;
    return PyUnicode_FromStringAndSize(s, n);
}

static PyObject *short_float_cached(PyObject *self, PyObject *arg)
{
    double x = PyFloat_AsDouble(arg);
    if (x == -1.0 && PyErr_Occurred())
        return NULL;
    char s[48];
    int n = short_repr_cached(x, s);
    if (n == 0)
        Py_RETURN_NONE;
    return PyUnicode_FromStringAndSize(s, n);
}

static PyObject *text_form(PyObject *self, PyObject *arg)
{
    if (!PyUnicode_CheckExact(arg)) {
        PyErr_SetString(PyExc_TypeError, "text_form takes a str");
        return NULL;
    }
#if PY_VERSION_HEX < 0x030C0000
    if (PyUnicode_READY(arg) < 0)
        return NULL;
#endif
    if (!PyUnicode_IS_ASCII(arg))
        Py_RETURN_NONE;
    const unsigned char *u = (const unsigned char *)PyUnicode_DATA(arg);
    Py_ssize_t n = PyUnicode_GET_LENGTH(arg);
    int form = ascii_text_form(u, n);
    if (form < 0)
        Py_RETURN_NONE;
    char stack_buf[256];
    buf_t b = {stack_buf, 0, (Py_ssize_t)sizeof stack_buf, 0, 1};
    int rc = form == 0 ? buf_put(&b, (const char *)u, n) : buf_put_json_ascii(&b, u, n);
    PyObject *r = rc < 0 ? NULL : PyUnicode_FromStringAndSize(b.p, b.n);
    if (b.heap)
        PyMem_Free(b.p);
    return r;
}

static PyMethodDef methods[] = {
    UVN_PROBE_METHOD,
    {"render_rows", (PyCFunction)(void (*)(void))render_rows, METH_FASTCALL,
     "render_rows(rows, dumps, format_text, format_value) -> str | None\n\n"
     "The text of (prefix, keys, values) rows as engine.io.outlog._render_rows_py writes it;\n"
     "None where the Python must render them. dumps: orjson.dumps (probed) or None (repr)."},
    {"cycle_rows", (PyCFunction)(void (*)(void))cycle_rows, METH_FASTCALL,
     "cycle_rows(r, consts) -> list | None\n\n"
     "The rows OutLogWriter.write_cycle renders for engine.run.records.cycle_block(r); None\n"
     "where the Python must build them. consts: engine.run.records._CYCLE_CONSTS."},
    {"cycle_text", (PyCFunction)(void (*)(void))cycle_text, METH_FASTCALL,
     "cycle_text(r, consts, dumps, format_text, format_value) -> str | None\n\n"
     "render_rows(cycle_rows(r, consts), ...): the whole .OUT block of a CycleResult in one\n"
     "call; None where the Python must build or write it."},
    {"cycle_writer", (PyCFunction)(void (*)(void))cycle_writer, METH_FASTCALL,
     "cycle_writer(consts, dumps, format_text, format_value) -> write(r, fd)\n\n"
     "cycle_text bound to its constants, writing the block's UTF-8 bytes to fd itself:\n"
     "write returns their number, or None (nothing written) where the Python must write."},
    {"freeze_result", (PyCFunction)(void (*)(void))freeze_result, METH_FASTCALL,
     "freeze_result(fix, phi, u1, u2) -> True | None\n\n"
     "engine.run.cycle._freeze_result's arrays made read-only; None: left to the Python."},
    {"float_repr", float_repr, METH_O,
     "float_repr(x) -> repr(float(x)) by PyOS_double_to_string('r', Py_DTSF_ADD_DOT_0)."},
    {"short_checked", short_checked, METH_NOARGS,
     "short_checked() -> bool: short_float wrote its probes as repr (then cycle_text uses it)."},
    {"fixed3_float", fixed3_float, METH_O,
     "fixed3_float(x) -> format(float(x), '.3f') by the kernel's exact rounding, or None where\n"
     "it leaves x to PyOS_double_to_string (nan, inf, |x| >= 2**53)."},
    {"short_float", short_float, METH_O,
     "short_float(x) -> repr(float(x)) by the kernel's own shortest digits, or None where it\n"
     "leaves x to repr's routine (subnormals, the exponent forms)."},
    {"short_float_cached", short_float_cached, METH_O,
     "short_float_cached(x) -> short_float(x) through the table of the last texts written\n"
     "(the path cycle_text takes): the same text, or None, for the same x."},
    {"text_form", text_form, METH_O,
     "text_form(word) -> outlog._format_text(word) where decided in C, else None."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "outfmt",
    "Compiled .OUT cycle block text (engine/native/outfmt.c); same characters as "
    "engine.io.outlog._render_rows_py.",
    -1, methods,
};

PyMODINIT_FUNC PyInit_outfmt(void)
{
    init_classes();
    init_pow5();
    if (init_cycle_names() < 0 || freeze_names() < 0)
        return NULL;
    PyDateTime_IMPORT; /* NULL (error cleared): the time stamp by the Python function */
    if (PyDateTimeAPI == NULL)
        PyErr_Clear();
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
