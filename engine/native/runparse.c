/* The .RUN reader's quick parser (engine.fast.runfile): one usual record (each GPS coordinate
 * four tokens or one '-', 6-9 numeric columns, no key=value) to a RunRecord, or None where the
 * reference's checked parser (engine.io.runfile.parse_run_line) decides, which then gives the
 * same record or the located error.
 *
 * Accepts only what the checked parser accepts: printable ASCII or tab only, split on
 * blanks/tabs, YYMMDD HHMMSS (datetime checks the values), D M S.sss H with parse_dms's rules,
 * numeric columns of [0-9.-] converted by PyOS_string_to_double (what float(str) calls) and
 * range-checked with the same comparisons; lat = d + m / 60.0 + s / 3600.0 in that order.
 * The record is made as object.__new__ plus object.__setattr__ per field makes it
 * (the type's tp_alloc slot, PyObject_GenericSetAttr), bound once by bind().
 * Also the cycle's small objects made in one call: make (frozen slots dataclasses), make_attrs
 * (frozen dataclasses with an instance dict) and prior (engine.run.cycle's provisional
 * position), and untrack: a kept cycle result out of the cyclic GC's lists
 * (engine.fast.retained). Public C API only, and of CPython's the limited API's functions but
 * for the datetime C API (datetime.h) and numpy's (uvn_numpy.h, prior). */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <datetime.h>
#include "uvn_numpy.h" /* numpy arrays through numpy's C API (prior) */
#include <math.h>
#include <string.h>

#define N_SLOTS 17
#define MAX_TOKS 19
#define MAX_TOK_CHARS 63

static PyTypeObject *g_cls = NULL;
static allocfunc g_alloc = NULL;  /* g_cls's tp_alloc (PyType_GetSlot) */
static PyObject *g_names = NULL;  /* tuple of the 17 field names, field order */
static PyObject *g_tz = NULL;

/* A type's tp_alloc, as object.__new__ calls it (NULL with TypeError if it has none). */
static allocfunc
alloc_of(PyTypeObject *tp)
{
    allocfunc alloc = (allocfunc)PyType_GetSlot(tp, Py_tp_alloc);
    if (alloc == NULL && !PyErr_Occurred())
        PyErr_SetString(PyExc_TypeError, "the class has no tp_alloc");
    return alloc;
}

static PyObject *
rp_bind(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3 || !PyType_Check(args[0]) || !PyTuple_CheckExact(args[1])
        || PyTuple_Size(args[1]) != N_SLOTS) {
        PyErr_SetString(PyExc_TypeError, "bind(cls, names[17], tzinfo)");
        return NULL;
    }
    allocfunc alloc = alloc_of((PyTypeObject *)args[0]);
    if (alloc == NULL)
        return NULL;
    PyObject *old[3] = {(PyObject *)g_cls, g_names, g_tz};
    g_cls = (PyTypeObject *)Py_NewRef(args[0]);
    g_alloc = alloc;
    g_names = Py_NewRef(args[1]);
    g_tz = Py_NewRef(args[2]);
    for (int i = 0; i < 3; i++)
        Py_XDECREF(old[i]);
    Py_RETURN_NONE;
}

static int
all_digits(const char *p, Py_ssize_t n)
{
    if (n < 1)
        return 0;
    for (Py_ssize_t i = 0; i < n; i++)
        if (p[i] < '0' || p[i] > '9')
            return 0;
    return 1;
}

/* s.replace(".", "", 1).isdigit(): digits with at most one '.', at least one digit. */
static int
decimal_digits(const char *p, Py_ssize_t n)
{
    int dots = 0, digits = 0;
    for (Py_ssize_t i = 0; i < n; i++) {
        if (p[i] == '.') {
            if (++dots > 1)
                return 0;
        }
        else if (p[i] >= '0' && p[i] <= '9')
            digits++;
        else
            return 0;
    }
    return digits > 0;
}

/* float(token): 1 and *out on success, 0 where float() would raise, -1 on another error. */
static int
to_double(const char *p, Py_ssize_t n, double *out)
{
    char small[MAX_TOK_CHARS + 1];
    char *end;
    if (n < 1)
        return 0;
    char *buf = small;
    if (n > MAX_TOK_CHARS) {
        buf = PyMem_Malloc((size_t)n + 1);
        if (buf == NULL) {
            PyErr_NoMemory();
            return -1;
        }
    }
    memcpy(buf, p, (size_t)n);
    buf[n] = '\0';
    int rc = 1;
    double v = PyOS_string_to_double(buf, &end, NULL);
    if (v == -1.0 && PyErr_Occurred()) {
        if (PyErr_ExceptionMatches(PyExc_ValueError)) {
            PyErr_Clear();
            rc = 0;
        }
        else
            rc = -1;
    }
    else if (end != buf + n)
        rc = 0;
    else
        *out = v;
    if (buf != small)
        PyMem_Free(buf);
    return rc;
}

/* object.__setattr__(obj, names[i], value): 0, or -1 (exception set). Steals value. */
static int
set_slot(PyObject *obj, Py_ssize_t i, PyObject *value)
{
    if (value == NULL)
        return -1;
    int rc = PyObject_GenericSetAttr(obj, PyTuple_GetItem(g_names, i), value);
    Py_DECREF(value);
    return rc;
}

static PyObject *
float_or_none(int present, double v)
{
    if (!present)
        Py_RETURN_NONE;
    return PyFloat_FromDouble(v);
}

PyDoc_STRVAR(record_doc,
"record(line, line_no) -> RunRecord | None\n\n"
"The record of a usual .RUN line, or None where engine.io.runfile.parse_run_line decides\n"
"(bind() first; None before that).");

static PyObject *
rp_record(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "record(line, line_no)");
        return NULL;
    }
    PyObject *line = args[0];
    if (g_cls == NULL || !PyUnicode_Check(line))
        Py_RETURN_NONE;
    Py_ssize_t len;
    const char *s = PyUnicode_AsUTF8AndSize(line, &len); /* ASCII: the str's own bytes */
    if (s == NULL) {
        if (!PyErr_ExceptionMatches(PyExc_UnicodeError))
            return NULL;
        PyErr_Clear(); /* a lone surrogate: the checked parser's message */
        Py_RETURN_NONE;
    }
    Py_ssize_t end = len; /* bytes = characters below: anything not ASCII is declined */
    while (end > 0 && (s[end - 1] == '\r' || s[end - 1] == '\n'))
        end--;
    /* printable ASCII or tab (the separators check), no '=' (key=value records) */
    for (Py_ssize_t i = 0; i < end; i++) {
        char c = s[i];
        if (c == '=' || (c != '\t' && (c < 0x20 || c > 0x7e)))
            Py_RETURN_NONE;
    }
    const char *tp[MAX_TOKS];
    Py_ssize_t tn[MAX_TOKS];
    int n = 0;
    Py_ssize_t i = 0;
    while (i < end) {
        while (i < end && (s[i] == ' ' || s[i] == '\t'))
            i++;
        if (i >= end)
            break;
        Py_ssize_t j = i;
        while (j < end && s[j] != ' ' && s[j] != '\t')
            j++;
        if (n == MAX_TOKS)
            Py_RETURN_NONE;
        tp[n] = s + i;
        tn[n] = j - i;
        n++;
        i = j;
    }
    if (n < 10)
        Py_RETURN_NONE;
    /* date and time */
    if (tn[0] != 6 || tn[1] != 6 || !all_digits(tp[0], 6) || !all_digits(tp[1], 6))
        Py_RETURN_NONE;
    const char *d = tp[0], *t = tp[1];
    int yy = (d[0] - '0') * 10 + (d[1] - '0');
    int month = (d[2] - '0') * 10 + (d[3] - '0');
    int day = (d[4] - '0') * 10 + (d[5] - '0');
    int hh = (t[0] - '0') * 10 + (t[1] - '0');
    int minute = (t[2] - '0') * 10 + (t[3] - '0');
    int second = (t[4] - '0') * 10 + (t[5] - '0');
    /* GPS latitude and longitude: one '-' or parse_dms's fast path (n >= 10: the four
     * tokens exist); b: the next token */
    double ll[2] = {0.0, 0.0};
    int has_ll[2] = {0, 0};
    int b = 2;
    for (int k = 0; k < 2; k++) {
        if (tn[b] == 1 && tp[b][0] == '-') {
            b++;
            continue;
        }
        if (!all_digits(tp[b], tn[b]) || !all_digits(tp[b + 1], tn[b + 1])
            || !decimal_digits(tp[b + 2], tn[b + 2]))
            Py_RETURN_NONE;
        double dv, mv, sv;
        int r1 = to_double(tp[b + 1], tn[b + 1], &mv);
        int r2 = r1 == 1 ? to_double(tp[b + 2], tn[b + 2], &sv) : r1;
        int r3 = r2 == 1 ? to_double(tp[b], tn[b], &dv) : r2;
        if (r3 < 0)
            return NULL;
        if (r3 == 0)
            Py_RETURN_NONE;
        if (!(mv < 60.0 && sv < 60.0))
            Py_RETURN_NONE;
        double value = dv + mv / 60.0 + sv / 3600.0;
        if (!(value <= (k == 0 ? 90.0 : 180.0)))
            Py_RETURN_NONE;
        if (tn[b + 3] != 1)
            Py_RETURN_NONE;
        char h = tp[b + 3][0];
        if (h == (k == 0 ? 'S' : 'W'))
            value = -value;
        else if (h != (k == 0 ? 'N' : 'E'))
            Py_RETURN_NONE;
        ll[k] = value;
        has_ll[k] = 1;
        b += 4;
    }
    if (n - b < 6 || n - b > 9)
        Py_RETURN_NONE;
    /* the numeric columns */
    double v[9];
    int present[9];
    for (int k = 0; k < 9; k++) {
        v[k] = 0.0;
        present[k] = 0;
    }
    for (int k = b; k < n; k++) {
        for (Py_ssize_t c = 0; c < tn[k]; c++) {
            char ch = tp[k][c];
            if (!((ch >= '0' && ch <= '9') || ch == '.' || ch == '-'))
                Py_RETURN_NONE;
        }
    }
    for (int k = b; k < n; k++) {
        if (tn[k] == 1 && tp[k][0] == '-')
            continue;
        int r = to_double(tp[k], tn[k], &v[k - b]);
        if (r < 0)
            return NULL;
        if (r == 0)
            Py_RETURN_NONE;
        present[k - b] = 1;
    }
    if ((present[0] && !(0.0 <= v[0] && v[0] < 1.0))
        || (present[1] && !(0.0 <= v[1] && v[1] < 1.0))
        || (present[2] && !(0.0 <= v[2] && v[2] < 1.0))
        || (present[3] && !(0.0 <= v[3] && v[3] < 360.0))
        || (present[4] && !(0.0 <= v[4] && v[4] <= 60.0))
        || (present[5] && !(-90.0 <= v[5] && v[5] <= 90.0))
        || (present[6] && !(-90.0 <= v[6] && v[6] <= 90.0))
        || (present[7] && !(v[7] > 0.0 && isfinite(v[7])))
        || (present[8] && !(v[8] >= 0.0 && isfinite(v[8]))))
        Py_RETURN_NONE;
    PyObject *time = PyDateTimeAPI->DateTime_FromDateAndTime(
        yy + (yy >= 70 ? 1900 : 2000), month, day, hh, minute, second, 0, g_tz,
        PyDateTimeAPI->DateTimeType);
    if (time == NULL) {
        if (!PyErr_ExceptionMatches(PyExc_ValueError))
            return NULL;
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    PyObject *rec = g_alloc(g_cls, 0);
    if (rec == NULL) {
        Py_DECREF(time);
        return NULL;
    }
    PyObject *decca = PyTuple_New(3);
    if (decca == NULL)
        goto fail_time;
    for (int k = 0; k < 3; k++) {
        PyObject *f = float_or_none(present[k], v[k]);
        if (f == NULL) {
            Py_DECREF(decca);
            goto fail_time;
        }
        PyTuple_SetItem(decca, k, f); /* steals f; cannot fail on a new tuple */
    }
    /* set_slot steals its value: time and decca are released here until a slot holds them */
    if (set_slot(rec, 0, Py_NewRef(args[1])) < 0) {
        Py_DECREF(decca);
        goto fail_time;
    }
    if (set_slot(rec, 1, time) < 0 || set_slot(rec, 2, float_or_none(has_ll[0], ll[0])) < 0
        || set_slot(rec, 3, float_or_none(has_ll[1], ll[1])) < 0) {
        Py_DECREF(decca);
        goto fail;
    }
    if (set_slot(rec, 4, decca) < 0)
        goto fail;
    for (int k = 3; k < 9; k++)
        if (set_slot(rec, 2 + k, float_or_none(present[k], v[k])) < 0)
            goto fail;
    if (set_slot(rec, 11, PyUnicode_Substring(line, 0, end)) < 0)
        goto fail;
    for (int k = 12; k < N_SLOTS; k++)
        if (set_slot(rec, k, Py_NewRef(Py_None)) < 0)
            goto fail;
    return rec;
fail_time:
    Py_DECREF(time);
fail:
    Py_DECREF(rec);
    return NULL;
}

/* object.__new__(cls) with object.__setattr__(obj, names[i], values[i]) for each i (a name
 * that is not a str: TypeError from PyObject_GenericSetAttr). */
static PyObject *
make_with(PyObject *cls, PyObject *names, PyObject *const *values, Py_ssize_t n)
{
    PyTypeObject *tp = (PyTypeObject *)cls;
    allocfunc alloc = alloc_of(tp);
    if (alloc == NULL)
        return NULL;
    PyObject *obj = alloc(tp, 0);
    if (obj == NULL)
        return NULL;
    for (Py_ssize_t i = 0; i < n; i++)
        if (PyObject_GenericSetAttr(obj, PyTuple_GetItem(names, i), values[i]) < 0) {
            Py_DECREF(obj);
            return NULL;
        }
    return obj;
}

PyDoc_STRVAR(make_doc,
"make(cls, names, *values) -> cls instance\n\n"
"A frozen dataclass instance made as its __init__ makes it when given every field\n"
"positionally (object.__new__, then object.__setattr__(obj, names[i], values[i]) in field\n"
"order), without the Python frames. names: the field names, in field order.");

static PyObject *
rp_make(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < 2 || !PyType_Check(args[0]) || !PyTuple_CheckExact(args[1])
        || PyTuple_Size(args[1]) != nargs - 2) {
        PyErr_SetString(PyExc_TypeError, "make(cls, names, *values): one value per name");
        return NULL;
    }
    return make_with(args[0], args[1], args + 2, nargs - 2);
}

PyDoc_STRVAR(make_attrs_doc,
"make_attrs(cls, names, *values) -> cls instance\n\n"
"A frozen dataclass instance without slots (an instance dict) made as object.__new__(cls)\n"
"and its __dict__ filled with names[i] = values[i] (object.__setattr__'s generic store, past\n"
"the class's frozen __setattr__): the instance engine.systems.base.new_reading makes.\n"
"names: a tuple of str, one per value.");

static PyObject *
rp_make_attrs(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs < 2 || !PyType_Check(args[0]) || !PyTuple_CheckExact(args[1])
        || PyTuple_Size(args[1]) != nargs - 2) {
        PyErr_SetString(PyExc_TypeError, "make_attrs(cls, names, *values): one value per name");
        return NULL;
    }
    return make_with(args[0], args[1], args + 2, nargs - 2);
}

PyDoc_STRVAR(prior_doc,
"prior(x, P, ix, iy, make) -> ((x, y), make(x, y, cov)) or None\n\n"
"engine.run.cycle._provisional's filter part: x[ix:iy + 1].tolist() and\n"
"make(x, y, P[ix:iy + 1, ix:iy + 1].copy()) for float64 numpy arrays x (1-D) and P (2-D) read\n"
"through uvn_numpy.h, iy == ix + 1; None for anything else (the Python runs).");

static PyObject *
rp_prior(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    np_fields_t *fx, *fp;
    Py_ssize_t ix, iy;
    double x, y, *data;
    PyObject *cov, *xo, *yo, *made, *a[3];
    if (nargs != 5 || !PyLong_CheckExact(args[2]) || !PyLong_CheckExact(args[3]))
        Py_RETURN_NONE;
    if (np_layout < 0 && np_ready() < 0) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    ix = PyLong_AsSsize_t(args[2]);
    iy = PyLong_AsSsize_t(args[3]);
    if (ix < 0 || iy != ix + 1) {
        PyErr_Clear();
        Py_RETURN_NONE;
    }
    fx = np_direct(args[0], 1);
    fp = np_direct(args[1], 2);
    if (fx == NULL || fp == NULL || iy >= PyArray_DIMS(fx)[0] || iy >= PyArray_DIMS(fp)[0]
        || iy >= PyArray_DIMS(fp)[1])
        Py_RETURN_NONE;
    x = *(double *)(PyArray_BYTES(fx) + ix * PyArray_STRIDES(fx)[0]);
    y = *(double *)(PyArray_BYTES(fx) + iy * PyArray_STRIDES(fx)[0]);
    cov = new_array(2, 2, 2, &data);
    if (cov == NULL)
        return NULL;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++)
            data[2 * i + j] =
                *(double *)(PyArray_BYTES(fp) + (ix + i) * PyArray_STRIDES(fp)[0] + (ix + j) * PyArray_STRIDES(fp)[1]);
    xo = PyFloat_FromDouble(x);
    yo = PyFloat_FromDouble(y);
    if (xo == NULL || yo == NULL) {
        Py_XDECREF(xo);
        Py_XDECREF(yo);
        Py_DECREF(cov);
        return NULL;
    }
    a[0] = xo;
    a[1] = yo;
    a[2] = cov;
    made = PyObject_Vectorcall(args[4], a, 3, NULL);
    Py_DECREF(cov);
    if (made == NULL) {
        Py_DECREF(xo);
        Py_DECREF(yo);
        return NULL;
    }
    return Py_BuildValue("((NN)N)", xo, yo, made);
}

/* untrack: the walk over one kept result (a DAG of frozen records and tuples). */
typedef struct {
    PyObject *kinds;    /* dict: type -> True/False (frozen record or not), filled on demand */
    PyObject *classify; /* callable(type) -> bool, asked once per type */
    int depth;
} untrack_ctx;

/* 1: a frozen record type, 0: not, -1: error (classify failed). */
static int
untrack_kind(PyTypeObject *tp, untrack_ctx *c)
{
    PyObject *kind = PyDict_GetItemWithError(c->kinds, (PyObject *)tp);
    if (kind == NULL) {
        if (PyErr_Occurred())
            return -1;
        kind = PyObject_CallOneArg(c->classify, (PyObject *)tp);
        if (kind == NULL)
            return -1;
        int ok = PyDict_SetItem(c->kinds, (PyObject *)tp, kind);
        Py_DECREF(kind); /* the dict holds it */
        if (ok < 0)
            return -1;
    }
    return kind == Py_True;
}

/* The collector tracks o (0 for an object of a type without GC support). */
static int
gc_tracked(PyObject *o)
{
    return PyObject_GC_IsTracked(o);
}

static int untrack_walk(PyObject *o, untrack_ctx *c);

static int
untrack_visit(PyObject *o, void *arg)
{
    return untrack_walk(o, (untrack_ctx *)arg);
}

/* 0, or -1 with an exception set (the classify callable failed). Objects not tracked are
 * left alone and not entered: atomic ones, ones CPython untracked (tuples and dicts of
 * atomic values) and ones a walk untracked before (their children were walked then). */
static int
untrack_walk(PyObject *o, untrack_ctx *c)
{
    if (!gc_tracked(o) || c->depth > 64)
        return 0;
    if (PyDict_CheckExact(o)) {
        /* a record's instance dict (or a dict field): its values walked, the dict itself
         * untracked only when no key or value is tracked any more, CPython's own rule for
         * dicts (and CPython tracks it again if a container is stored in it later) */
        Py_ssize_t pos = 0;
        PyObject *k, *v;
        int none_tracked = 1;
        c->depth++;
        while (PyDict_Next(o, &pos, &k, &v)) {
            if (untrack_walk(v, c) < 0) {
                c->depth--;
                return -1;
            }
            if (gc_tracked(k) || gc_tracked(v))
                none_tracked = 0;
        }
        c->depth--;
        if (none_tracked)
            PyObject_GC_UnTrack(o);
        return 0;
    }
    if (!PyTuple_CheckExact(o)) {
        if (PyType_Check(o))
            return 0; /* a record's class (visited by its traverse) */
        int kind = untrack_kind(Py_TYPE(o), c);
        if (kind < 0)
            return -1;
        if (kind == 0)
            return 0; /* a list, a mutable object: stays tracked, not entered */
    }
    traverseproc traverse = (traverseproc)PyType_GetSlot(Py_TYPE(o), Py_tp_traverse);
    if (traverse == NULL) {
        if (PyErr_Occurred())
            return -1;
        return 0; /* nothing to enter (a GC type always has one) */
    }
    c->depth++;
    int r = traverse(o, untrack_visit, c);
    c->depth--;
    if (r < 0)
        return -1;
    PyObject_GC_UnTrack(o);
    return 0;
}

PyDoc_STRVAR(untrack_doc,
"untrack(obj, kinds, classify) -> None\n\n"
"Take obj and what it holds out of the cyclic garbage collector's lists, depth first: exact\n"
"tuples, and instances of the types classify(type) calls frozen records (asked once per\n"
"type, the answer kept in the dict kinds); an exact dict (a record's instance dict) has its\n"
"values walked and is untracked when none of its keys and values is tracked any more.\n"
"Anything else it meets (a list, a mutable object, a type) stays tracked and is not\n"
"entered. Reference counting frees the objects as before; only a reference cycle through\n"
"them would no longer be found (engine.run.retained).");

static PyObject *
rp_untrack(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 3 || !PyDict_CheckExact(args[1]) || !PyCallable_Check(args[2])) {
        PyErr_SetString(PyExc_TypeError, "untrack(obj, kinds: dict, classify: callable)");
        return NULL;
    }
    untrack_ctx c = {args[1], args[2], 0};
    if (untrack_walk(args[0], &c) < 0)
        return NULL;
    Py_RETURN_NONE;
}

static PyMethodDef rp_methods[] = {
    UVN_PROBE_METHOD,
    {"make", (PyCFunction)(void (*)(void))rp_make, METH_FASTCALL, make_doc},
    {"prior", (PyCFunction)(void (*)(void))rp_prior, METH_FASTCALL, prior_doc},
    {"make_attrs", (PyCFunction)(void (*)(void))rp_make_attrs, METH_FASTCALL,
     make_attrs_doc},
    {"bind", (PyCFunction)(void (*)(void))rp_bind, METH_FASTCALL,
     "bind(cls, names, tzinfo): the RunRecord class, its 17 field names, UTC."},
    {"record", (PyCFunction)(void (*)(void))rp_record, METH_FASTCALL, record_doc},
    {"untrack", (PyCFunction)(void (*)(void))rp_untrack, METH_FASTCALL, untrack_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef rp_module = {
    PyModuleDef_HEAD_INIT, "runparse",
    "The .RUN reader's quick parser (engine.fast.runfile) and the cycle's small-object\n"
    "makers: the records engine.io.runfile.parse_run_line gives, in one call.",
    -1, rp_methods,
};

PyMODINIT_FUNC
PyInit_runparse(void)
{
    PyDateTime_IMPORT;
    if (PyDateTimeAPI == NULL)
        return NULL;
    PyObject *m = PyModule_Create(&rp_module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddStringConstant(m, "SOURCE_DIGEST", UVN_SOURCE_DIGEST) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
