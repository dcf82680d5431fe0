/* Elimination orders walked: eliminate, and the network order restricted to a plan
 * (restrict). */
#include "orders.h"

/* The labels of a call, numbered densely: variable id u -> u, other label u < 0 -> top - u
 * (top = the largest variable id), with each one's size. */
typedef struct {
    Py_ssize_t top, n;
    count_t *size;
    char *seen; /* whether the label occurs in the call's scopes or output */
} labels_t;

static Py_ssize_t dense(const labels_t *L, long u) { return u >= 0 ? u : L->top - u; }

static long label_of(const labels_t *L, Py_ssize_t d) {
    return d <= L->top ? (long)d : (long)(L->top - d);
}

/* The smallest and largest label of `scopes` and `output` (sequences of ints). */
int orders_read_range(PyObject *scopes_fast, PyObject *output_fast, long *lo, long *hi) {
    *lo = 0;
    *hi = -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(scopes_fast);
    for (Py_ssize_t k = -1; k < n; k++) {
        PyObject *scope = k < 0 ? output_fast : PySequence_Fast_GET_ITEM(scopes_fast, k);
        PyObject *fast = PySequence_Fast(scope, "a scope must be a sequence of labels");
        if (fast == NULL) return -1;
        Py_ssize_t m = PySequence_Fast_GET_SIZE(fast);
        for (Py_ssize_t j = 0; j < m; j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
            if (u == -1 && PyErr_Occurred()) {
                Py_DECREF(fast);
                return -1;
            }
            if (u < *lo) *lo = u;
            if (u > *hi) *hi = u;
        }
        Py_DECREF(fast);
    }
    if (*hi - *lo > (1L << 24)) {
        PyErr_SetString(PyExc_ValueError, "labels span more than 2**24 values");
        return -1;
    }
    return 0;
}

static int labels_init(labels_t *L, long lo, long hi) {
    L->top = hi < 0 ? -1 : hi;
    L->n = L->top + 1 - lo;
    L->size = PyMem_Calloc((size_t)L->n + 1, sizeof(count_t));
    L->seen = PyMem_Calloc((size_t)L->n + 1, 1);
    if (L->size == NULL || L->seen == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

static void labels_free(labels_t *L) {
    PyMem_Free(L->size);
    PyMem_Free(L->seen);
}

/* Mark label u seen and look its size up (card[u] or extra[u]). */
static int labels_see(labels_t *L, long u, PyObject *card, PyObject *extra) {
    Py_ssize_t d = dense(L, u);
    if (L->seen[d]) return 0;
    PyObject *item;
    if (u >= 0) {
        item = PySequence_GetItem(card, u);
    } else {
        if (extra == Py_None) {
            PyErr_Format(PyExc_KeyError, "label %ld has no size", u);
            return -1;
        }
        PyObject *key = PyLong_FromLong(u);
        if (key == NULL) return -1;
        item = PyObject_GetItem(extra, key);
        Py_DECREF(key);
    }
    if (item == NULL) return -1;
    unsigned long long s = PyLong_AsUnsignedLongLong(item);
    Py_DECREF(item);
    if (s == (unsigned long long)-1 && PyErr_Occurred()) return -1;
    L->size[d] = (count_t)s;
    L->seen[d] = 1;
    return 0;
}

static PyObject *label_tuple(const labels_t *L, const Py_ssize_t *ds, Py_ssize_t n) {
    PyObject *t = PyTuple_New(n);
    if (t == NULL) return NULL;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *x = PyLong_FromLong(label_of(L, ds[k]));
        if (x == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, k, x);
    }
    return t;
}

PyObject *orders_int_tuple(const Py_ssize_t *xs, Py_ssize_t n) {
    PyObject *t = PyTuple_New(n);
    if (t == NULL) return NULL;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *x = PyLong_FromSsize_t(xs[k]);
        if (x == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, k, x);
    }
    return t;
}

/* ---- eliminate ------------------------------------------------------------------------ */

typedef struct {
    labels_t L;
    vec pool;       /* every operand's labels, dense, one after another */
    vec start, len; /* each operand's labels: pool[start[k] : start[k] + len[k]] */
    vec open;       /* 1 while an operand is not yet joined */
    vec fixed;      /* whether each operand is evidence-free (with `constant`) */
    vec *holders;   /* per dense label: live operands holding it, oldest first */
    char *in_output;
    Py_ssize_t *mark; /* per dense label: the step that last put it in a union */
    vec chosen, uni, kept;
} walk_t;

static void walk_free(walk_t *w) {
    if (w->holders != NULL) {
        for (Py_ssize_t d = 0; d < w->L.n; d++) PyMem_Free(w->holders[d].a);
    }
    PyMem_Free(w->holders);
    PyMem_Free(w->in_output);
    PyMem_Free(w->mark);
    PyMem_Free(w->pool.a);
    PyMem_Free(w->start.a);
    PyMem_Free(w->len.a);
    PyMem_Free(w->open.a);
    PyMem_Free(w->fixed.a);
    PyMem_Free(w->chosen.a);
    PyMem_Free(w->uni.a);
    PyMem_Free(w->kept.a);
    labels_free(&w->L);
}

/* The product of the operands in w->chosen: w->uni its labels in order of first
 * appearance; return its entries. With `join`, the operands are consumed: w->kept gets the
 * labels still held elsewhere (or in the output) and becomes a new operand. */
static int walk_join(walk_t *w, Py_ssize_t step, int join, count_t *entries) {
    Py_ssize_t result = w->start.n;
    w->uni.n = 0;
    count_t product = 1;
    for (Py_ssize_t c = 0; c < w->chosen.n; c++) {
        Py_ssize_t i = w->chosen.a[c];
        if (join) w->open.a[i] = 0;
        Py_ssize_t s = w->start.a[i], m = w->len.a[i];
        for (Py_ssize_t j = 0; j < m; j++) {
            Py_ssize_t d = w->pool.a[s + j];
            if (w->mark[d] != step) {
                w->mark[d] = step;
                if (vec_push(&w->uni, d) < 0) return -1;
                product = mul_sat(product, w->L.size[d]);
            }
            if (join) vec_remove(&w->holders[d], i);
        }
    }
    *entries = product;
    if (!join) return 0;
    w->kept.n = 0;
    Py_ssize_t begin = w->pool.n;
    for (Py_ssize_t k = 0; k < w->uni.n; k++) {
        Py_ssize_t d = w->uni.a[k];
        if (w->holders[d].n > 0 || w->in_output[d]) {
            if (vec_push(&w->kept, d) < 0 || vec_push(&w->pool, d) < 0) return -1;
            if (vec_push(&w->holders[d], result) < 0) return -1;
        }
    }
    if (vec_push(&w->start, begin) < 0 || vec_push(&w->len, w->kept.n) < 0 ||
        vec_push(&w->open, 1) < 0)
        return -1;
    return 0;
}

static PyObject *record_step(walk_t *w, PyObject *path, PyObject *kept_steps, PyObject *records,
                             PyObject *kept_labels, count_t entries) {
    PyObject *chosen = orders_int_tuple(w->chosen.a, w->chosen.n);
    PyObject *uni = label_tuple(&w->L, w->uni.a, w->uni.n);
    PyObject *kept = kept_labels != NULL ? (Py_INCREF(kept_labels), kept_labels)
                                         : label_tuple(&w->L, w->kept.a, w->kept.n);
    PyObject *count = PyLong_FromUnsignedLongLong(entries);
    PyObject *record = NULL;
    int ok = chosen && uni && kept && count;
    if (ok) record = PyTuple_Pack(2, count, uni);
    ok = ok && record && PyList_Append(path, chosen) == 0 && PyList_Append(kept_steps, kept) == 0 &&
         PyList_Append(records, record) == 0;
    Py_XDECREF(chosen);
    Py_XDECREF(uni);
    Py_XDECREF(kept);
    Py_XDECREF(count);
    Py_XDECREF(record);
    return ok ? Py_None : NULL;
}

/* One step of the walk over the operands in w->chosen: joined and recorded (the last step,
 * `output` given, only recorded, its kept labels the output). 1 once recorded, 0 when the
 * running `total` passes `bound` (or every step is `refused`), -1 on error. */
static int take_step(walk_t *w, Py_ssize_t step, PyObject *output, count_t *total, int refused,
                     count_t bound, PyObject *path, PyObject *kept_steps, PyObject *records) {
    count_t entries;
    if (walk_join(w, step, output == NULL, &entries) < 0) return -1;
    *total = add_sat(*total, entries);
    if (refused || *total > bound) return 0;
    return record_step(w, path, kept_steps, records, output, entries) == NULL ? -1 : 1;
}

PyObject *orders_eliminate(PyObject *self, PyObject *args) {
    PyObject *scopes, *labels, *output, *card, *extra, *constant, *limit;
    if (!PyArg_ParseTuple(args, "OOOOOOO", &scopes, &labels, &output, &card, &extra, &constant,
                          &limit))
        return NULL;
    /* the cost bound: none, or a count (a negative one fails at the first step; one past
     * 2**64 - 1 is never reached by saturating totals) */
    count_t bound = UINT64_MAX;
    int refused = 0;
    if (limit != Py_None) {
        int overflow;
        long long small = PyLong_AsLongLongAndOverflow(limit, &overflow);
        if (small == -1 && PyErr_Occurred()) return NULL;
        if (overflow < 0 || (!overflow && small < 0))
            refused = 1;
        else if (!overflow)
            bound = (count_t)small;
    }
    walk_t w;
    memset(&w, 0, sizeof w);
    PyObject *scopes_fast = NULL, *labels_fast = NULL, *output_fast = NULL;
    PyObject *path = NULL, *kept_steps = NULL, *records = NULL, *result = NULL;
    vec deferred = {0};
    long lo, hi;
    scopes_fast = PySequence_Fast(scopes, "scopes must be a sequence");
    labels_fast = PySequence_Fast(labels, "labels must be a sequence");
    output_fast = PySequence_Fast(output, "output must be a sequence");
    if (!scopes_fast || !labels_fast || !output_fast) goto done;
    if (orders_read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
    if (labels_init(&w.L, lo, hi) < 0) goto done;
    w.holders = PyMem_Calloc((size_t)w.L.n + 1, sizeof(vec));
    w.in_output = PyMem_Calloc((size_t)w.L.n + 1, 1);
    w.mark = PyMem_Malloc(((size_t)w.L.n + 1) * sizeof(Py_ssize_t));
    if (!w.holders || !w.in_output || !w.mark) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t d = 0; d <= w.L.n; d++) w.mark[d] = -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(scopes_fast);
    int with_constant = constant != Py_None;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *fast = PySequence_Fast(PySequence_Fast_GET_ITEM(scopes_fast, k), "a scope");
        if (fast == NULL) goto done;
        Py_ssize_t m = PySequence_Fast_GET_SIZE(fast);
        if (vec_push(&w.start, w.pool.n) < 0 || vec_push(&w.len, m) < 0 ||
            vec_push(&w.open, 1) < 0) {
            Py_DECREF(fast);
            goto done;
        }
        for (Py_ssize_t j = 0; j < m; j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
            Py_ssize_t d = dense(&w.L, u);
            if (labels_see(&w.L, u, card, extra) < 0 || vec_push(&w.pool, d) < 0 ||
                vec_push(&w.holders[d], k) < 0) {
                Py_DECREF(fast);
                goto done;
            }
        }
        Py_DECREF(fast);
        if (with_constant) {
            PyObject *item = PySequence_GetItem(constant, k);
            if (item == NULL) goto done;
            int truth = PyObject_IsTrue(item);
            Py_DECREF(item);
            if (truth < 0) goto done;
            if (vec_push(&w.fixed, truth) < 0) goto done;
        }
    }
    Py_ssize_t n_output = PySequence_Fast_GET_SIZE(output_fast);
    for (Py_ssize_t j = 0; j < n_output; j++) {
        long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(output_fast, j));
        if (labels_see(&w.L, u, card, extra) < 0) goto done;
        w.in_output[dense(&w.L, u)] = 1;
    }
    path = PyList_New(0);
    kept_steps = PyList_New(0);
    records = PyList_New(0);
    if (!path || !kept_steps || !records) goto done;
    count_t total = 0;
    Py_ssize_t step = 0;
    Py_ssize_t n_labels = PySequence_Fast_GET_SIZE(labels_fast);
    for (int round = 0; round < (with_constant ? 2 : 1); round++) {
        Py_ssize_t n_round = round == 0 ? n_labels : deferred.n;
        for (Py_ssize_t r = 0; r < n_round; r++) {
            long u;
            if (round == 0) {
                u = PyLong_AsLong(PySequence_Fast_GET_ITEM(labels_fast, r));
                if (u == -1 && PyErr_Occurred()) goto done;
            } else {
                u = (long)deferred.a[r];
            }
            if (u < lo || u > hi) continue;
            Py_ssize_t d = dense(&w.L, u);
            vec *held = &w.holders[d];
            if (held->n == 0) continue;
            w.chosen.n = 0;
            int fixed = 1;
            for (Py_ssize_t c = 0; c < held->n; c++) {
                if (vec_push(&w.chosen, held->a[c]) < 0) goto done;
                if (with_constant && !w.fixed.a[held->a[c]]) fixed = 0;
            }
            if (with_constant) {
                if (!fixed && round == 0) {
                    if (vec_push(&deferred, u) < 0) goto done;
                    continue;
                }
                if (vec_push(&w.fixed, fixed) < 0) goto done;
            }
            int taken =
                take_step(&w, step++, NULL, &total, refused, bound, path, kept_steps, records);
            if (taken <= 0) {
                if (taken == 0) result = Py_NewRef(Py_None);
                goto done;
            }
        }
    }
    w.chosen.n = 0;
    for (Py_ssize_t i = 0; i < w.open.n; i++) {
        if (w.open.a[i] && vec_push(&w.chosen, i) < 0) goto done;
    }
    if (w.chosen.n > 1 || PyList_GET_SIZE(path) == 0) {
        PyObject *out = PySequence_Tuple(output_fast);
        if (out == NULL) goto done;
        int taken = take_step(&w, step++, out, &total, refused, bound, path, kept_steps, records);
        Py_DECREF(out);
        if (taken <= 0) {
            if (taken == 0) result = Py_NewRef(Py_None);
            goto done;
        }
    }
    result = Py_BuildValue("(OOOK)", path, kept_steps, records, (unsigned long long)total);
done:
    Py_XDECREF(scopes_fast);
    Py_XDECREF(labels_fast);
    Py_XDECREF(output_fast);
    Py_XDECREF(path);
    Py_XDECREF(kept_steps);
    Py_XDECREF(records);
    PyMem_Free(deferred.a);
    walk_free(&w);
    return result;
}

typedef struct {
    long long place;
    long label;
} placed_t;

static int by_place(const void *a, const void *b) {
    long long x = ((const placed_t *)a)->place, y = ((const placed_t *)b)->place;
    return (x > y) - (x < y);
}

/* restrict(scopes, output, positions, weights, bound) -> labels | None
 *
 * The labels of `scopes` that are not in `output`, in the order of `positions` (each
 * variable's place in the network-wide elimination order, by id), or None when their
 * `weights` (each variable's weight there) sum to more than `bound`. */
PyObject *orders_restrict_order(PyObject *self, PyObject *args) {
    PyObject *scopes, *output, *positions, *weights, *bound_obj;
    if (!PyArg_ParseTuple(args, "OOOOO", &scopes, &output, &positions, &weights, &bound_obj))
        return NULL;
    int overflow;
    unsigned long long bound = ULLONG_MAX;
    long long small = PyLong_AsLongLongAndOverflow(bound_obj, &overflow);
    if (small == -1 && PyErr_Occurred()) return NULL;
    int refused = overflow < 0 || (!overflow && small < 0);
    if (!overflow && small >= 0) bound = (unsigned long long)small;
    PyObject *scopes_fast = NULL, *output_fast = NULL, *result = NULL;
    char *mark = NULL;
    placed_t *chosen = NULL;
    long lo, hi;
    scopes_fast = PySequence_Fast(scopes, "scopes must be a sequence");
    output_fast = PySequence_Fast(output, "output must be a sequence");
    if (!scopes_fast || !output_fast) goto done;
    if (orders_read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
    if (lo < 0) {
        PyErr_SetString(PyExc_ValueError, "a network order has variables only");
        goto done;
    }
    mark = PyMem_Calloc((size_t)hi + 2, 1);
    chosen = PyMem_Malloc(((size_t)hi + 2) * sizeof(placed_t));
    if (!mark || !chosen) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t j = 0; j < PySequence_Fast_GET_SIZE(output_fast); j++)
        mark[PyLong_AsLong(PySequence_Fast_GET_ITEM(output_fast, j))] = 1;
    Py_ssize_t n_chosen = 0;
    count_t total = 0;
    for (Py_ssize_t k = 0; k < PySequence_Fast_GET_SIZE(scopes_fast); k++) {
        PyObject *fast = PySequence_Fast(PySequence_Fast_GET_ITEM(scopes_fast, k), "a scope");
        if (fast == NULL) goto done;
        for (Py_ssize_t j = 0; j < PySequence_Fast_GET_SIZE(fast); j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
            if (mark[u]) continue;
            mark[u] = 1;
            PyObject *p = PySequence_GetItem(positions, u);
            PyObject *w = p ? PySequence_GetItem(weights, u) : NULL;
            long long at = p ? PyLong_AsLongLong(p) : -1;
            unsigned long long weight = w ? PyLong_AsUnsignedLongLong(w) : 0;
            Py_XDECREF(p);
            Py_XDECREF(w);
            if (PyErr_Occurred()) {
                Py_DECREF(fast);
                goto done;
            }
            total = add_sat(total, (count_t)weight);
            chosen[n_chosen].place = at;
            chosen[n_chosen++].label = u;
        }
        Py_DECREF(fast);
    }
    if (refused || total > bound) {
        result = Py_None;
        Py_INCREF(result);
        goto done;
    }
    qsort(chosen, (size_t)n_chosen, sizeof(placed_t), by_place);
    result = PyList_New(n_chosen);
    for (Py_ssize_t k = 0; result != NULL && k < n_chosen; k++) {
        PyObject *x = PyLong_FromLong(chosen[k].label);
        if (x == NULL) Py_CLEAR(result);
        else PyList_SET_ITEM(result, k, x);
    }
done:
    Py_XDECREF(scopes_fast);
    Py_XDECREF(output_fast);
    PyMem_Free(mark);
    PyMem_Free(chosen);
    return result;
}
