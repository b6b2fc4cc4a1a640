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
 * No floating-point arithmetic is done here: only texts are copied.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

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
        int form = ascii_text_form(u, n);
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

static PyObject *render_rows(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError,
                        "render_rows(rows, dumps, format_text, format_value) takes 4 arguments");
        return NULL;
    }
    PyObject *rows = args[0], *dumps = args[1], *format_text = args[2],
             *format_value = args[3];
    if (!PyList_CheckExact(rows))
        Py_RETURN_NONE;
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
    {"render_rows", (PyCFunction)(void (*)(void))render_rows, METH_FASTCALL,
     "render_rows(rows, dumps, format_text, format_value) -> str | None\n\n"
     "The text of (prefix, keys, values) rows as engine.io.outlog._render_rows_py writes it;\n"
     "None where the Python must render them. dumps: orjson.dumps (probed) or None (repr)."},
    {"float_repr", float_repr, METH_O,
     "float_repr(x) -> repr(float(x)) by PyOS_double_to_string('r', Py_DTSF_ADD_DOT_0)."},
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
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
