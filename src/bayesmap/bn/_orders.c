/* Elimination orders of a pattern's first question, compiled.
 *
 * A Bayesian network's first question of a new evidence pattern walks an elimination order
 * over the pattern's factors (bayesmap.bn.plans.order_steps): which factors each summed-out
 * variable joins, the labels their product keeps, the entries of each step. In Python that
 * walk is a few thousand interpreter steps per question, most of what a cold question costs
 * beside the arithmetic; here it is the same walk over integer arrays. Two functions:
 *
 *   eliminate(scopes, labels, output, card, extra, constant, limit)
 *       Sum `labels` out in this order, each with the factors then holding it, then join
 *       what is left into `output` (bayesmap.bn.plans.order_steps documents the deferral of
 *       steps that join evidence-dependent factors, `constant`, and the cost bound
 *       `limit`). Returns (path, kept, records, total), or None once the steps cost more
 *       than `limit` multiply-adds.
 *
 *   min_weight(scopes, output, card, weights)
 *       The greedy min-weight elimination order of the factors' interaction graph (Koller &
 *       Friedman 2009, section 9.4.3.2): each label's position, and the sum of the weights
 *       of its eliminations; `weights`, a dict or None, receives each label's weight.
 *
 * Labels are Python ints: variable ids (>= 0, sized by `card`) and other labels (< 0, the
 * case axis of a batch, sized by the dict `extra`). Entries and weights are unsigned 64-bit
 * integers that saturate at 2**64 - 1: a step that large is 2**37 times over the largest
 * table bayesmap will build (elimination.MAX_STEP_ENTRIES), so no question that can be
 * answered is ordered differently from exact integers.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>
#include <stdlib.h>
#include <limits.h>
#include <string.h>

typedef uint64_t count_t;

static count_t mul_sat(count_t a, count_t b) {
    count_t r;
    return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
}

static count_t add_sat(count_t a, count_t b) {
    count_t r;
    return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
}

/* A growable array of Py_ssize_t. */
typedef struct {
    Py_ssize_t *a;
    Py_ssize_t n, cap;
} vec;

static int vec_push(vec *v, Py_ssize_t x) {
    if (v->n == v->cap) {
        Py_ssize_t cap = v->cap ? 2 * v->cap : 8;
        Py_ssize_t *a = PyMem_Realloc(v->a, (size_t)cap * sizeof(Py_ssize_t));
        if (a == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        v->a = a;
        v->cap = cap;
    }
    v->a[v->n++] = x;
    return 0;
}

static void vec_remove(vec *v, Py_ssize_t x) {
    for (Py_ssize_t k = 0; k < v->n; k++) {
        if (v->a[k] == x) {
            memmove(v->a + k, v->a + k + 1, (size_t)(v->n - k - 1) * sizeof(Py_ssize_t));
            v->n--;
            return;
        }
    }
}

/* The labels of a call, numbered densely: variable id u -> u, other label u < 0 -> top - u
 * (top = the largest variable id), with each one's size. */
typedef struct {
    Py_ssize_t top, n;
    count_t *size;
    char *seen; /* whether the label occurs in the call's scopes or output */
} labels_t;

static Py_ssize_t dense(const labels_t *L, long u) { return u >= 0 ? u : L->top - u; }

static long label_of(const labels_t *L, Py_ssize_t d) { return d <= L->top ? (long)d : (long)(L->top - d); }

/* Read `scopes` (a list of sequences of int) into PySequence_Fast objects, finding the
 * label range. */
static int read_range(PyObject *scopes_fast, PyObject *output_fast, long *lo, long *hi) {
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

static PyObject *index_tuple(const Py_ssize_t *xs, Py_ssize_t n) {
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
    PyObject *chosen = index_tuple(w->chosen.a, w->chosen.n);
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

static PyObject *eliminate(PyObject *self, PyObject *args) {
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
    if (read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
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
            count_t entries;
            if (walk_join(&w, step++, 1, &entries) < 0) goto done;
            total = add_sat(total, entries);
            if (refused || total > bound) {
                result = Py_None;
                Py_INCREF(result);
                goto done;
            }
            if (record_step(&w, path, kept_steps, records, NULL, entries) == NULL) goto done;
        }
    }
    w.chosen.n = 0;
    for (Py_ssize_t i = 0; i < w.open.n; i++) {
        if (w.open.a[i] && vec_push(&w.chosen, i) < 0) goto done;
    }
    if (w.chosen.n > 1 || PyList_GET_SIZE(path) == 0) {
        count_t entries;
        if (walk_join(&w, step++, 0, &entries) < 0) goto done;
        total = add_sat(total, entries);
        if (refused || total > bound) {
            result = Py_None;
            Py_INCREF(result);
            goto done;
        }
        PyObject *out = PySequence_Tuple(output_fast);
        if (out == NULL) goto done;
        PyObject *ok = record_step(&w, path, kept_steps, records, out, entries);
        Py_DECREF(out);
        if (ok == NULL) goto done;
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
static PyObject *restrict_order(PyObject *self, PyObject *args) {
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
    if (read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
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

/* ---- min_weight ----------------------------------------------------------------------- */

typedef struct {
    count_t weight;
    long label;
    Py_ssize_t node;
} entry_t;

static int entry_less(const entry_t *a, const entry_t *b) {
    return a->weight < b->weight || (a->weight == b->weight && a->label < b->label);
}

typedef struct {
    entry_t *a;
    Py_ssize_t n, cap;
} heap_t;

static int heap_push(heap_t *h, entry_t e) {
    if (h->n == h->cap) {
        Py_ssize_t cap = h->cap ? 2 * h->cap : 64;
        entry_t *a = PyMem_Realloc(h->a, (size_t)cap * sizeof(entry_t));
        if (a == NULL) {
            PyErr_NoMemory();
            return -1;
        }
        h->a = a;
        h->cap = cap;
    }
    Py_ssize_t k = h->n++;
    while (k > 0) {
        Py_ssize_t parent = (k - 1) / 2;
        if (!entry_less(&e, &h->a[parent])) break;
        h->a[k] = h->a[parent];
        k = parent;
    }
    h->a[k] = e;
    return 0;
}

static entry_t heap_pop(heap_t *h) {
    entry_t top = h->a[0], last = h->a[--h->n];
    Py_ssize_t k = 0;
    for (;;) {
        Py_ssize_t child = 2 * k + 1;
        if (child >= h->n) break;
        if (child + 1 < h->n && entry_less(&h->a[child + 1], &h->a[child])) child++;
        if (!entry_less(&h->a[child], &last)) break;
        h->a[k] = h->a[child];
        k = child;
    }
    if (h->n > 0) h->a[k] = last;
    return top;
}

/* The entries of x's factor: its size times its neighbours'. */
static count_t node_weight(const uint64_t *row, Py_ssize_t words, const count_t *size,
                           Py_ssize_t x) {
    count_t w = size[x];
    for (Py_ssize_t k = 0; k < words; k++) {
        uint64_t bits = row[k];
        while (bits) {
            int b = __builtin_ctzll(bits);
            bits &= bits - 1;
            w = mul_sat(w, size[k * 64 + b]);
        }
    }
    return w;
}

static PyObject *min_weight(PyObject *self, PyObject *args) {
    PyObject *scopes, *output, *card, *weights;
    if (!PyArg_ParseTuple(args, "OOOO", &scopes, &output, &card, &weights)) return NULL;
    PyObject *scopes_fast = NULL, *output_fast = NULL, *rank = NULL, *result = NULL;
    Py_ssize_t *node_of = NULL, m = 0, words = 0;
    long *label = NULL;
    count_t *size = NULL, *current = NULL;
    char *alive = NULL;
    uint64_t *adj = NULL;
    vec members = {0};
    heap_t heap = {0};
    long lo, hi;
    scopes_fast = PySequence_Fast(scopes, "scopes must be a sequence");
    output_fast = PySequence_Fast(output, "output must be a sequence");
    if (!scopes_fast || !output_fast) goto done;
    if (read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
    /* the variables (labels >= 0) of the scopes, numbered 0..m-1 as first met */
    node_of = PyMem_Malloc(((size_t)(hi < 0 ? 0 : hi) + 1) * sizeof(Py_ssize_t));
    label = PyMem_Malloc(((size_t)(hi < 0 ? 0 : hi) + 1) * sizeof(long));
    if (!node_of || !label) {
        PyErr_NoMemory();
        goto done;
    }
    for (long u = 0; u <= hi; u++) node_of[u] = -1;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(scopes_fast);
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *fast = PySequence_Fast(PySequence_Fast_GET_ITEM(scopes_fast, k), "a scope");
        if (fast == NULL) goto done;
        for (Py_ssize_t j = 0; j < PySequence_Fast_GET_SIZE(fast); j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
            if (u >= 0 && node_of[u] < 0) {
                label[m] = u;
                node_of[u] = m++;
            }
        }
        Py_DECREF(fast);
    }
    words = (m + 63) / 64;
    size = PyMem_Calloc((size_t)m + 1, sizeof(count_t));
    current = PyMem_Calloc((size_t)m + 1, sizeof(count_t));
    alive = PyMem_Calloc((size_t)m + 1, 1);
    adj = PyMem_Calloc((size_t)(m * words) + 1, sizeof(uint64_t));
    if (!size || !current || !alive || !adj) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t x = 0; x < m; x++) {
        PyObject *item = PySequence_GetItem(card, label[x]);
        if (item == NULL) goto done;
        size[x] = (count_t)PyLong_AsUnsignedLongLong(item);
        Py_DECREF(item);
        if (PyErr_Occurred()) goto done;
        alive[x] = 1;
    }
    /* the interaction graph: the variables of each scope linked */
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *fast = PySequence_Fast(PySequence_Fast_GET_ITEM(scopes_fast, k), "a scope");
        if (fast == NULL) goto done;
        members.n = 0;
        for (Py_ssize_t j = 0; j < PySequence_Fast_GET_SIZE(fast); j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, j));
            if (u >= 0 && vec_push(&members, node_of[u]) < 0) {
                Py_DECREF(fast);
                goto done;
            }
        }
        Py_DECREF(fast);
        for (Py_ssize_t a = 0; a < members.n; a++) {
            uint64_t *row = adj + members.a[a] * words;
            for (Py_ssize_t b = 0; b < members.n; b++) {
                Py_ssize_t y = members.a[b];
                row[y / 64] |= (uint64_t)1 << (y % 64);
            }
        }
    }
    for (Py_ssize_t j = 0; j < PySequence_Fast_GET_SIZE(output_fast); j++) {
        long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(output_fast, j));
        if (u >= 0 && u <= hi && node_of[u] >= 0) alive[node_of[u]] = 0;
    }
    for (Py_ssize_t x = 0; x < m; x++) {
        uint64_t *row = adj + x * words;
        row[x / 64] &= ~((uint64_t)1 << (x % 64));
        if (alive[x]) {
            current[x] = node_weight(row, words, size, x);
            if (heap_push(&heap, (entry_t){current[x], label[x], x}) < 0) goto done;
        }
    }
    rank = PyDict_New();
    if (rank == NULL) goto done;
    count_t bound = 0;
    Py_ssize_t position = 0;
    uint64_t *around = PyMem_Malloc(((size_t)words + 1) * sizeof(uint64_t));
    if (around == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    while (heap.n > 0) {
        entry_t e = heap_pop(&heap);
        Py_ssize_t u = e.node;
        if (!alive[u] || current[u] != e.weight) continue; /* ranked, or reweighed since */
        alive[u] = 0;
        bound = add_sat(bound, e.weight);
        PyObject *key = PyLong_FromLong(e.label);
        PyObject *pos = PyLong_FromSsize_t(position++);
        PyObject *w = PyLong_FromUnsignedLongLong(e.weight);
        int bad = !key || !pos || !w || PyDict_SetItem(rank, key, pos) < 0 ||
                  (weights != Py_None && PyDict_SetItem(weights, key, w) < 0);
        Py_XDECREF(key);
        Py_XDECREF(pos);
        Py_XDECREF(w);
        if (bad) {
            PyMem_Free(around);
            goto done;
        }
        memcpy(around, adj + u * words, (size_t)words * sizeof(uint64_t));
        memset(adj + u * words, 0, (size_t)words * sizeof(uint64_t));
        for (Py_ssize_t k = 0; k < words; k++) {
            uint64_t bits = around[k];
            while (bits) {
                int b = __builtin_ctzll(bits);
                bits &= bits - 1;
                Py_ssize_t x = k * 64 + b;
                uint64_t *row = adj + x * words;
                for (Py_ssize_t j = 0; j < words; j++) row[j] |= around[j];
                row[u / 64] &= ~((uint64_t)1 << (u % 64));
                row[x / 64] &= ~((uint64_t)1 << (x % 64));
                if (alive[x]) {
                    count_t weight = node_weight(row, words, size, x);
                    if (weight != current[x]) {
                        current[x] = weight;
                        if (heap_push(&heap, (entry_t){weight, label[x], x}) < 0) {
                            PyMem_Free(around);
                            goto done;
                        }
                    }
                }
            }
        }
    }
    PyMem_Free(around);
    result = Py_BuildValue("(OK)", rank, (unsigned long long)bound);
done:
    Py_XDECREF(scopes_fast);
    Py_XDECREF(output_fast);
    Py_XDECREF(rank);
    PyMem_Free(node_of);
    PyMem_Free(label);
    PyMem_Free(size);
    PyMem_Free(current);
    PyMem_Free(alive);
    PyMem_Free(adj);
    PyMem_Free(members.a);
    PyMem_Free(heap.a);
    return result;
}

/* ---- pruning ------------------------------------------------------------------------- */

/* A network's variable sets as bit rows (Compiled.mask_table): a header (n, words), then
 * per variable its lineage (itself and its ancestors), ancestors, the children of its
 * ancestors ("reach") and family (itself and its parents), each `words` 64-bit words; the
 * data nodes; and the topological order and each variable's place in it. */
typedef struct {
    int64_t n, words;
    const uint64_t *lineage, *ancestors, *reach, *family, *sources;
    const int64_t *topo, *topo_pos;
} table_t;

static int read_table(PyObject *blob, table_t *t) {
    if (!PyBytes_Check(blob) || PyBytes_GET_SIZE(blob) < 16) {
        PyErr_SetString(PyExc_TypeError, "not a mask table");
        return -1;
    }
    const char *at = PyBytes_AS_STRING(blob);
    memcpy(&t->n, at, 8);
    memcpy(&t->words, at + 8, 8);
    int64_t row = t->n * t->words;
    Py_ssize_t expected = 16 + (Py_ssize_t)((4 * row + t->words) * 8 + 2 * t->n * 8);
    if (t->n < 0 || t->words < 1 || PyBytes_GET_SIZE(blob) != expected) {
        PyErr_SetString(PyExc_ValueError, "a mask table of the wrong size");
        return -1;
    }
    const uint64_t *words = (const uint64_t *)(at + 16);
    t->lineage = words;
    t->ancestors = words + row;
    t->reach = words + 2 * row;
    t->family = words + 3 * row;
    t->sources = words + 4 * row;
    t->topo = (const int64_t *)(t->sources + t->words);
    t->topo_pos = t->topo + t->n;
    return 0;
}

#define BIT(mask, v) (((mask)[(v) / 64] >> ((v) % 64)) & 1)

static int any_and(const uint64_t *a, const uint64_t *b, int64_t words) {
    for (int64_t k = 0; k < words; k++)
        if (a[k] & b[k]) return 1;
    return 0;
}

static int is_zero(const uint64_t *a, int64_t words) {
    for (int64_t k = 0; k < words; k++)
        if (a[k]) return 0;
    return 1;
}

/* Read a sequence of variable ids (each < n) into `out`; -1 on error. */
static Py_ssize_t read_ids(PyObject *seq, int64_t n, int64_t **out) {
    PyObject *fast = PySequence_Fast(seq, "variable ids must be a sequence");
    if (fast == NULL) return -1;
    Py_ssize_t m = PySequence_Fast_GET_SIZE(fast);
    *out = PyMem_Malloc(((size_t)m + 1) * sizeof(int64_t));
    if (*out == NULL) {
        Py_DECREF(fast);
        PyErr_NoMemory();
        return -1;
    }
    for (Py_ssize_t k = 0; k < m; k++) {
        long v = PyLong_AsLong(PySequence_Fast_GET_ITEM(fast, k));
        if (v < 0 || v >= n) {
            if (!PyErr_Occurred()) PyErr_Format(PyExc_IndexError, "no variable %ld", v);
            Py_DECREF(fast);
            return -1;
        }
        (*out)[k] = v;
    }
    Py_DECREF(fast);
    return m;
}

static PyObject *id_list(const int64_t *ids, Py_ssize_t n, int as_tuple) {
    PyObject *out = as_tuple ? PyTuple_New(n) : PyList_New(n);
    if (out == NULL) return NULL;
    for (Py_ssize_t k = 0; k < n; k++) {
        PyObject *x = PyLong_FromLongLong(ids[k]);
        if (x == NULL) {
            Py_DECREF(out);
            return NULL;
        }
        if (as_tuple)
            PyTuple_SET_ITEM(out, k, x);
        else
            PyList_SET_ITEM(out, k, x);
    }
    return out;
}

/* Sort a few ids ascending by key[id] (or by id, with key NULL): an insertion sort. */
static void sort_ids(int64_t *ids, Py_ssize_t n, const int64_t *key) {
    for (Py_ssize_t i = 1; i < n; i++) {
        int64_t x = ids[i], kx = key ? key[x] : x;
        Py_ssize_t j = i;
        for (; j > 0 && (key ? key[ids[j - 1]] : ids[j - 1]) > kx; j--) ids[j] = ids[j - 1];
        ids[j] = x;
    }
}

/* prune(table, targets, evidence, kind, priors) -> (kept, replaced, dropped)
 *
 * Which CPTs a question's plan keeps (bayesmap.bn.plans.build documents the steps): kind 0
 * (marginal) keeps the targets, the evidence and their ancestors, and the connected
 * component of the targets; kind 1 (evidence) all components; kind 2 (whole) every
 * variable. With `priors`, each maximal evidence-free ancestral sub-network that meets the
 * rest through one variable is replaced by that variable's prior, and a single target that
 * the evidence cannot reach is answered by its prior alone. Returns the kept
 * variables in topological order (their CPTs, or priors for those in `replaced`, in the
 * order they were found, last first), and the observed variables whose CPTs were dropped,
 * ascending. */
static PyObject *prune(PyObject *self, PyObject *args) {
    PyObject *blob, *targets_obj, *evidence_obj;
    int kind, priors;
    if (!PyArg_ParseTuple(args, "OOOip", &blob, &targets_obj, &evidence_obj, &kind, &priors))
        return NULL;
    table_t t;
    if (read_table(blob, &t) < 0) return NULL;
    int64_t W = t.words, n = t.n;
    int64_t *targets = NULL, *evidence = NULL, *relevant = NULL, *kept = NULL, *replaced = NULL;
    int64_t *dropped = NULL;
    uint64_t *work = NULL, *scope = NULL;
    PyObject *result = NULL;
    Py_ssize_t n_targets = read_ids(targets_obj, n, &targets);
    Py_ssize_t n_evidence = n_targets < 0 ? -1 : read_ids(evidence_obj, n, &evidence);
    if (n_targets < 0 || n_evidence < 0) goto done;
    /* working rows: evidence, its lineage, targets, relevant, skip, covered, reached, before */
    work = PyMem_Calloc((size_t)(8 * W), sizeof(uint64_t));
    relevant = PyMem_Malloc(((size_t)n + n_evidence + 2) * sizeof(int64_t));
    kept = PyMem_Malloc(((size_t)n + n_evidence + 2) * sizeof(int64_t));
    replaced = PyMem_Malloc(((size_t)n + 1) * sizeof(int64_t));
    dropped = PyMem_Malloc(((size_t)n_evidence + 1) * sizeof(int64_t));
    if (!work || !relevant || !kept || !replaced || !dropped) {
        PyErr_NoMemory();
        goto done;
    }
    uint64_t *ev = work, *ev_lineage = work + W, *tm = work + 2 * W, *r = work + 3 * W;
    uint64_t *skip = work + 4 * W, *covered = work + 5 * W, *reached = work + 6 * W;
    uint64_t *before = work + 7 * W;
    for (Py_ssize_t k = 0; k < n_evidence; k++) {
        int64_t v = evidence[k];
        ev[v / 64] |= (uint64_t)1 << (v % 64);
        for (int64_t j = 0; j < W; j++) ev_lineage[j] |= t.lineage[v * W + j];
    }
    for (Py_ssize_t k = 0; k < n_targets; k++) tm[targets[k] / 64] |= (uint64_t)1 << (targets[k] % 64);
    Py_ssize_t n_relevant = 0, n_kept = 0, n_replaced = 0, n_dropped = 0;
    int alone = 0;
    if (priors && n_evidence > 0 && n_targets == 1 && kind == 0) {
        int64_t v = targets[0];
        alone = 1;
        for (int64_t j = 0; j < W; j++)
            if (t.lineage[v * W + j] & (ev_lineage[j] | t.sources[j])) alone = 0;
    }
    if (alone) { /* the target's prior, with the evidence's checks */
        relevant[n_relevant++] = targets[0];
        for (Py_ssize_t k = 0; k < n_evidence; k++) relevant[n_relevant++] = evidence[k];
        sort_ids(relevant, n_relevant, t.topo_pos);
        replaced[n_replaced++] = targets[0];
    } else {
        if (kind == 2) {
            for (int64_t v = 0; v < n; v++) r[v / 64] |= (uint64_t)1 << (v % 64);
        } else {
            memcpy(r, ev_lineage, (size_t)W * sizeof(uint64_t));
            for (Py_ssize_t k = 0; k < n_targets; k++)
                for (int64_t j = 0; j < W; j++) r[j] |= t.lineage[targets[k] * W + j];
        }
        if (priors) { /* evidence-free ancestral sub-networks, the lowest first */
            for (int64_t j = 0; j < W; j++) skip[j] = ev[j] | tm[j] | t.sources[j];
            for (int64_t p = n - 1; p >= 0; p--) {
                int64_t v = t.topo[p];
                if (!BIT(r, v)) continue;
                const uint64_t *line = t.lineage + v * W, *anc = t.ancestors + v * W;
                if (any_and(line, skip, W) || is_zero(anc, W) || BIT(covered, v)) continue;
                int meets = 0;
                for (int64_t j = 0; j < W; j++)
                    if (t.reach[v * W + j] & r[j] & ~line[j]) meets = 1;
                if (meets) continue;
                replaced[n_replaced++] = v;
                for (int64_t j = 0; j < W; j++) covered[j] |= anc[j];
            }
            for (int64_t j = 0; j < W; j++) r[j] &= ~covered[j];
        }
        for (int64_t p = 0; p < n; p++)
            if (BIT(r, t.topo[p])) relevant[n_relevant++] = t.topo[p];
    }
    /* the free variables of each relevant CPT (of a replaced variable's prior: itself) */
    scope = PyMem_Calloc((size_t)(n_relevant * W) + 1, sizeof(uint64_t));
    if (scope == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t k = 0; k < n_relevant; k++) {
        int64_t v = relevant[k];
        int is_replaced = 0;
        for (Py_ssize_t i = 0; i < n_replaced; i++)
            if (replaced[i] == v) is_replaced = 1;
        uint64_t *row = scope + k * W;
        if (is_replaced)
            row[v / 64] |= (uint64_t)1 << (v % 64);
        else
            for (int64_t j = 0; j < W; j++) row[j] = t.family[v * W + j] & ~ev[j];
    }
    /* which CPTs stay: with one target the evidence cannot reach, those sharing a variable
     * with the target's prior; for a marginal, those in the targets' component (passes
     * over the scopes, alternately upwards and downwards, until one reaches nothing new);
     * otherwise all */
    int filtered = alone || kind == 0;
    memcpy(reached, tm, (size_t)W * sizeof(uint64_t));
    for (int pass = 0; kind == 0 && !alone; pass++) {
        memcpy(before, reached, (size_t)W * sizeof(uint64_t));
        for (Py_ssize_t i = 0; i < n_relevant; i++) {
            Py_ssize_t k = pass % 2 == 0 ? n_relevant - 1 - i : i;
            const uint64_t *row = scope + k * W;
            if (any_and(row, reached, W))
                for (int64_t j = 0; j < W; j++) reached[j] |= row[j];
        }
        if (memcmp(before, reached, (size_t)W * sizeof(uint64_t)) == 0) break;
    }
    for (Py_ssize_t k = 0; k < n_relevant; k++) {
        int64_t v = relevant[k];
        const uint64_t *row = scope + k * W;
        if (filtered && !is_zero(row, W) && !any_and(row, reached, W)) {
            if (BIT(ev, v)) dropped[n_dropped++] = v;
            continue;
        }
        kept[n_kept++] = v;
    }
    sort_ids(dropped, n_dropped, NULL);
    PyObject *kept_list = id_list(kept, n_kept, 0);
    PyObject *replaced_tuple = id_list(replaced, n_replaced, 1);
    PyObject *dropped_tuple = id_list(dropped, n_dropped, 1);
    if (kept_list && replaced_tuple && dropped_tuple)
        result = PyTuple_Pack(3, kept_list, replaced_tuple, dropped_tuple);
    Py_XDECREF(kept_list);
    Py_XDECREF(replaced_tuple);
    Py_XDECREF(dropped_tuple);
done:
    PyMem_Free(targets);
    PyMem_Free(evidence);
    PyMem_Free(relevant);
    PyMem_Free(kept);
    PyMem_Free(replaced);
    PyMem_Free(dropped);
    PyMem_Free(work);
    PyMem_Free(scope);
    return result;
}

/* ---- program steps -------------------------------------------------------------------- */

/* One step of a compiled sum-product program (bayesmap.bn.elimination.SumProgram): the
 * operands `chosen` (each a (value, register, labels) triple: a constant array and -1, or
 * None and the register it is read from), multiplied and summed into the labels `kept`.
 * Labels are numbered 0, 1, ... in `uni`'s order, as einsum's sub-lists. A step of constant
 * operands is looked up in `results` (the memo's dict, or None) by the identities of its
 * arrays, their labels and the kept labels, else computed by `constant(args, large, key,
 * inputs)`; any other step is appended to `steps` as (arguments, fills, register, large),
 * its register n_inputs + len(steps). Returns the step's result as a (value, register,
 * labels) triple. */
static PyObject *one_step(PyObject *chosen, PyObject *kept, PyObject *uni, int large,
                          PyObject *results, PyObject *steps, Py_ssize_t n_inputs,
                          PyObject *constant) {
    PyObject *chosen_fast = NULL, *uni_fast = NULL, *kept_fast = NULL, *key = NULL;
    PyObject *arguments = NULL, *fills = NULL, *inputs = NULL, *answer = NULL;
    long *numbers = NULL;
    chosen_fast = PySequence_Fast(chosen, "chosen must be a sequence");
    uni_fast = PySequence_Fast(uni, "union must be a sequence");
    kept_fast = PySequence_Tuple(kept);
    if (!chosen_fast || !uni_fast || !kept_fast) goto done;
    Py_ssize_t m = PySequence_Fast_GET_SIZE(chosen_fast);
    int per_call = 0;
    for (Py_ssize_t k = 0; k < m; k++) {
        PyObject *op = PySequence_Fast_GET_ITEM(chosen_fast, k);
        if (!PyTuple_Check(op) || PyTuple_GET_SIZE(op) != 3) {
            PyErr_SetString(PyExc_TypeError, "an operand is a (value, register, labels) triple");
            goto done;
        }
        Py_ssize_t source = PyLong_AsSsize_t(PyTuple_GET_ITEM(op, 1));
        if (source == -1 && PyErr_Occurred()) goto done;
        if (source >= 0) per_call = 1;
    }
    if (!per_call && results != Py_None) {
        key = PyTuple_New(m + 1);
        if (key == NULL) goto done;
        for (Py_ssize_t k = 0; k < m; k++) {
            PyObject *op = PySequence_Fast_GET_ITEM(chosen_fast, k);
            PyObject *ident = PyLong_FromVoidPtr(PyTuple_GET_ITEM(op, 0));
            PyObject *labels = ident ? PySequence_Tuple(PyTuple_GET_ITEM(op, 2)) : NULL;
            PyObject *pair = labels ? PyTuple_Pack(2, ident, labels) : NULL;
            Py_XDECREF(ident);
            Py_XDECREF(labels);
            if (pair == NULL) goto done;
            PyTuple_SET_ITEM(key, k, pair);
        }
        Py_INCREF(kept_fast);
        PyTuple_SET_ITEM(key, m, kept_fast);
        PyObject *found = PyDict_GetItemWithError(results, key); /* borrowed: (inputs, result) */
        if (found != NULL) { /* a step another program computed: (inputs, result) */
            answer = Py_BuildValue("(OiO)", PyTuple_GET_ITEM(found, 1), -1, kept_fast);
            goto done;
        }
        if (PyErr_Occurred()) goto done;
    }
    /* einsum's sub-lists: each label numbered by its place in the union */
    Py_ssize_t n_uni = PySequence_Fast_GET_SIZE(uni_fast);
    numbers = PyMem_Malloc(((size_t)n_uni + 1) * sizeof(long));
    if (numbers == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    for (Py_ssize_t j = 0; j < n_uni; j++) {
        numbers[j] = PyLong_AsLong(PySequence_Fast_GET_ITEM(uni_fast, j));
        if (numbers[j] == -1 && PyErr_Occurred()) goto done;
    }
    arguments = PyTuple_New(2 * m + 1);
    fills = PyList_New(0);
    if (!arguments || !fills) goto done;
    for (Py_ssize_t k = 0; k <= m; k++) {
        PyObject *labels = k < m ? PyTuple_GET_ITEM(PySequence_Fast_GET_ITEM(chosen_fast, k), 2)
                                 : kept_fast;
        PyObject *labels_fast = PySequence_Fast(labels, "labels must be a sequence");
        if (labels_fast == NULL) goto done;
        Py_ssize_t n_labels = PySequence_Fast_GET_SIZE(labels_fast);
        PyObject *sub = PyTuple_New(n_labels);
        if (sub == NULL) {
            Py_DECREF(labels_fast);
            goto done;
        }
        for (Py_ssize_t j = 0; j < n_labels; j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(labels_fast, j));
            Py_ssize_t at = 0;
            while (at < n_uni && numbers[at] != u) at++;
            PyObject *number = at < n_uni ? PyLong_FromSsize_t(at) : NULL;
            if (number == NULL) {
                if (!PyErr_Occurred())
                    PyErr_Format(PyExc_ValueError, "label %ld is not in the step's union", u);
                Py_DECREF(sub);
                Py_DECREF(labels_fast);
                goto done;
            }
            PyTuple_SET_ITEM(sub, j, number);
        }
        Py_DECREF(labels_fast);
        if (k == m) {
            PyTuple_SET_ITEM(arguments, 2 * m, sub);
            break;
        }
        PyObject *op = PySequence_Fast_GET_ITEM(chosen_fast, k);
        PyObject *value = PyTuple_GET_ITEM(op, 0);
        Py_ssize_t source = PyLong_AsSsize_t(PyTuple_GET_ITEM(op, 1));
        if (source >= 0) {
            PyObject *fill = Py_BuildValue("(nn)", 2 * k, source);
            if (fill == NULL || PyList_Append(fills, fill) < 0) {
                Py_XDECREF(fill);
                Py_DECREF(sub);
                goto done;
            }
            Py_DECREF(fill);
        }
        Py_INCREF(value);
        PyTuple_SET_ITEM(arguments, 2 * k, value);
        PyTuple_SET_ITEM(arguments, 2 * k + 1, sub);
    }
    if (!per_call) {
        inputs = PyTuple_New(m);
        if (inputs == NULL) goto done;
        for (Py_ssize_t k = 0; k < m; k++) {
            PyObject *value = PyTuple_GET_ITEM(PySequence_Fast_GET_ITEM(chosen_fast, k), 0);
            Py_INCREF(value);
            PyTuple_SET_ITEM(inputs, k, value);
        }
        PyObject *result = PyObject_CallFunction(constant, "OOOO", arguments,
                                                 large ? Py_True : Py_False,
                                                 key ? key : Py_None, inputs);
        if (result == NULL) goto done;
        answer = Py_BuildValue("(NiO)", result, -1, kept_fast);
        goto done;
    }
    Py_ssize_t register_ = n_inputs + PyList_GET_SIZE(steps);
    PyObject *fills_tuple = PyList_AsTuple(fills);
    PyObject *entry = fills_tuple ? Py_BuildValue("(ONnO)", arguments, fills_tuple, register_,
                                                  large ? Py_True : Py_False)
                                  : NULL;
    if (entry == NULL || PyList_Append(steps, entry) < 0) {
        Py_XDECREF(entry);
        goto done;
    }
    Py_DECREF(entry);
    answer = Py_BuildValue("(OnO)", Py_None, register_, kept_fast);
done:
    Py_XDECREF(chosen_fast);
    Py_XDECREF(uni_fast);
    Py_XDECREF(kept_fast);
    Py_XDECREF(key);
    Py_XDECREF(arguments);
    Py_XDECREF(fills);
    Py_XDECREF(inputs);
    PyMem_Free(numbers);
    return answer;
}

static PyObject *step(PyObject *self, PyObject *args) {
    PyObject *chosen, *kept, *uni, *results, *steps, *constant;
    int large;
    Py_ssize_t n_inputs;
    if (!PyArg_ParseTuple(args, "OOOpOO!nO", &chosen, &kept, &uni, &large, &results,
                          &PyList_Type, &steps, &n_inputs, &constant))
        return NULL;
    return one_step(chosen, kept, uni, large, results, steps, n_inputs, constant);
}

/* The steps of a walked order (eliminate's path, kept labels and records), appended to a
 * program: each step's operands are taken from `live` by SSA number and its result appended
 * to it. A step of more than two operands whose product passes `split_above` entries, or
 * of more than `max_operands`, or any whose product passes `max_entries`, goes to
 * `wide(chosen, kept, entries, union)` instead, which gives its result. */
static PyObject *emit(PyObject *self, PyObject *args) {
    PyObject *live, *path, *kept_steps, *records, *results, *steps, *constant, *wide;
    Py_ssize_t n_inputs, max_operands;
    unsigned long long blas_above, split_above, max_entries;
    if (!PyArg_ParseTuple(args, "O!OOOOO!nKKnKOO", &PyList_Type, &live, &path, &kept_steps,
                          &records, &results, &PyList_Type, &steps, &n_inputs, &blas_above,
                          &split_above, &max_operands, &max_entries, &constant, &wide))
        return NULL;
    PyObject *path_fast = PySequence_Fast(path, "path must be a sequence");
    PyObject *kept_fast = PySequence_Fast(kept_steps, "kept must be a sequence");
    PyObject *records_fast = PySequence_Fast(records, "records must be a sequence");
    PyObject *chosen = NULL, *ok = NULL;
    if (!path_fast || !kept_fast || !records_fast) goto done;
    Py_ssize_t n = PySequence_Fast_GET_SIZE(path_fast);
    if (PySequence_Fast_GET_SIZE(kept_fast) != n || PySequence_Fast_GET_SIZE(records_fast) != n) {
        PyErr_SetString(PyExc_ValueError, "path, kept labels and records differ in length");
        goto done;
    }
    for (Py_ssize_t s = 0; s < n; s++) {
        PyObject *position = PySequence_Fast(PySequence_Fast_GET_ITEM(path_fast, s), "a step");
        if (position == NULL) goto done;
        Py_ssize_t m = PySequence_Fast_GET_SIZE(position);
        chosen = PyList_New(m);
        if (chosen == NULL) {
            Py_DECREF(position);
            goto done;
        }
        for (Py_ssize_t k = 0; k < m; k++) {
            Py_ssize_t i = PyLong_AsSsize_t(PySequence_Fast_GET_ITEM(position, k));
            if (i < 0 || i >= PyList_GET_SIZE(live)) {
                if (!PyErr_Occurred()) PyErr_SetString(PyExc_IndexError, "no such operand");
                Py_DECREF(position);
                goto done;
            }
            PyObject *op = PyList_GET_ITEM(live, i);
            Py_INCREF(op);
            PyList_SET_ITEM(chosen, k, op);
        }
        Py_DECREF(position);
        PyObject *record = PySequence_Fast_GET_ITEM(records_fast, s);
        PyObject *kept = PySequence_Fast_GET_ITEM(kept_fast, s);
        if (!PyTuple_Check(record) || PyTuple_GET_SIZE(record) != 2) {
            PyErr_SetString(PyExc_TypeError, "a record is an (entries, union) pair");
            goto done;
        }
        PyObject *entries_obj = PyTuple_GET_ITEM(record, 0), *uni = PyTuple_GET_ITEM(record, 1);
        int overflow;
        long long entries = PyLong_AsLongLongAndOverflow(entries_obj, &overflow);
        if (entries == -1 && PyErr_Occurred()) goto done;
        PyObject *result;
        if (overflow || (unsigned long long)entries > max_entries ||
            (m > 2 && ((unsigned long long)entries > split_above || m > max_operands))) {
            result = PyObject_CallFunctionObjArgs(wide, chosen, kept, entries_obj, uni, NULL);
        } else {
            int large = m == 2 && (unsigned long long)entries > blas_above;
            result = one_step(chosen, kept, uni, large, results, steps, n_inputs, constant);
        }
        Py_CLEAR(chosen);
        if (result == NULL) goto done;
        int appended = PyList_Append(live, result);
        Py_DECREF(result);
        if (appended < 0) goto done;
    }
    ok = Py_None;
    Py_INCREF(ok);
done:
    Py_XDECREF(chosen);
    Py_XDECREF(path_fast);
    Py_XDECREF(kept_fast);
    Py_XDECREF(records_fast);
    return ok;
}

/* ---- small sum-products ---------------------------------------------------------------- */

static PyObject *numpy_empty, *numpy_float64, *numpy_einsum;

#define MAX_LABELS 64

/* einsum(a, labels_a, b, labels_b, ..., labels_out) in sub-list form, as numpy's C einsum:
 * over float64 operands whose product has at most `small_entries` entries, by one loop over
 * the product's entries here (numpy's einsum sets up an iterator per call, several
 * microseconds, and brings much more code and data into the caches than a Bayesian
 * network's small steps need); anything else (a large product, another dtype, a label
 * repeated in one operand, a broadcast axis, an implicit output) goes to numpy's einsum
 * unchanged. Sub-lists are tuples or lists of ints. */
static Py_ssize_t small_entries = 4096;

static PyObject *contract(PyObject *self, PyObject *args) {
    Py_ssize_t n_args = PyTuple_GET_SIZE(args);
    if (n_args < 3 || n_args % 2 == 0) return PyObject_Call(numpy_einsum, args, NULL);
    Py_ssize_t m = n_args / 2;
    Py_buffer views[32];
    Py_ssize_t n_views = 0;
    Py_ssize_t size[MAX_LABELS], out_stride[MAX_LABELS], idx[MAX_LABELS];
    Py_ssize_t strides[32][MAX_LABELS], offset[32];
    char seen[MAX_LABELS];
    const double *base[32];
    PyObject *result = NULL;
    int fallback = m > 32;
    memset(seen, 0, sizeof seen);
    memset(size, 0, sizeof size);
    memset(out_stride, 0, sizeof out_stride);
    Py_ssize_t n_labels = 0;
    for (Py_ssize_t k = 0; k < m && !fallback; k++) {
        PyObject *op = PyTuple_GET_ITEM(args, 2 * k);
        PyObject *labels = PyTuple_GET_ITEM(args, 2 * k + 1);
        if (!(PyTuple_Check(labels) || PyList_Check(labels)) || !PyObject_CheckBuffer(op)) {
            fallback = 1;
            break;
        }
        Py_buffer *view = &views[n_views];
        if (PyObject_GetBuffer(op, view, PyBUF_RECORDS_RO) < 0) {
            PyErr_Clear();
            fallback = 1;
            break;
        }
        n_views++;
        if (view->itemsize != 8 || view->format == NULL || strcmp(view->format, "d") != 0 ||
            view->ndim != PySequence_Fast_GET_SIZE(labels)) {
            fallback = 1;
            break;
        }
        base[k] = (const double *)view->buf;
        for (Py_ssize_t u = 0; u < MAX_LABELS; u++) strides[k][u] = 0;
        for (Py_ssize_t j = 0; j < view->ndim; j++) {
            long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(labels, j));
            if (u < 0 || u >= MAX_LABELS || strides[k][u] != 0 || view->strides[j] % 8 != 0) {
                PyErr_Clear();
                fallback = 1;
                break;
            }
            if (seen[u] && size[u] != view->shape[j]) {
                fallback = 1; /* numpy's einsum raises the error */
                break;
            }
            if (!seen[u]) {
                seen[u] = 1;
                size[u] = view->shape[j];
                if (u + 1 > n_labels) n_labels = u + 1;
            }
            /* a unit axis has stride 0 here: the loop never moves along it */
            strides[k][u] = view->shape[j] > 1 ? view->strides[j] / 8 : 0;
            if (strides[k][u] == 0 && view->shape[j] > 1) { /* a broadcast axis */
                fallback = 1;
                break;
            }
        }
        /* a repeated label (a diagonal) leaves a stride set twice: numpy's einsum does that */
        if (!fallback) {
            for (Py_ssize_t j = 0; j < view->ndim && !fallback; j++)
                for (Py_ssize_t i = 0; i < j; i++)
                    if (PyLong_AsLong(PySequence_Fast_GET_ITEM(labels, i)) ==
                        PyLong_AsLong(PySequence_Fast_GET_ITEM(labels, j)))
                        fallback = 1;
        }
    }
    PyObject *out_labels = PyTuple_GET_ITEM(args, n_args - 1);
    Py_ssize_t n_out = 0, out_shape[MAX_LABELS];
    long out_label[MAX_LABELS];
    Py_ssize_t entries = 1;
    if (!fallback) {
        if (!(PyTuple_Check(out_labels) || PyList_Check(out_labels)) ||
            PySequence_Fast_GET_SIZE(out_labels) > MAX_LABELS) {
            fallback = 1;
        } else {
            n_out = PySequence_Fast_GET_SIZE(out_labels);
            char in_out[MAX_LABELS];
            memset(in_out, 0, sizeof in_out);
            for (Py_ssize_t j = 0; j < n_out; j++) {
                long u = PyLong_AsLong(PySequence_Fast_GET_ITEM(out_labels, j));
                if (u < 0 || u >= MAX_LABELS || !seen[u] || in_out[u]) {
                    PyErr_Clear();
                    fallback = 1;
                    break;
                }
                in_out[u] = 1;
                out_label[j] = u;
                out_shape[j] = size[u];
            }
        }
        for (Py_ssize_t u = 0; u < n_labels && !fallback; u++) {
            if (seen[u]) {
                if (size[u] == 0 || entries > small_entries / size[u]) fallback = 1;
                entries *= size[u];
            }
        }
    }
    if (fallback) {
        for (Py_ssize_t k = 0; k < n_views; k++) PyBuffer_Release(&views[k]);
        return PyObject_Call(numpy_einsum, args, NULL);
    }
    /* the result, C-ordered over the output labels */
    PyObject *shape = PyTuple_New(n_out);
    if (shape == NULL) goto done;
    Py_ssize_t step = 1;
    for (Py_ssize_t j = n_out - 1; j >= 0; j--) {
        PyTuple_SET_ITEM(shape, j, PyLong_FromSsize_t(out_shape[j]));
        out_stride[out_label[j]] = out_shape[j] > 1 ? step : 0;
        step *= out_shape[j];
    }
    double total_scalar = 0.0;
    double *out = &total_scalar;
    Py_buffer out_view;
    int have_out = 0;
    if (n_out > 0) {
        result = PyObject_CallOneArg(numpy_empty, shape);
        Py_DECREF(shape);
        if (result == NULL) goto done;
        if (PyObject_GetBuffer(result, &out_view, PyBUF_CONTIG) < 0) {
            Py_CLEAR(result);
            goto done;
        }
        have_out = 1;
        out = (double *)out_view.buf;
        memset(out, 0, (size_t)step * sizeof(double));
    } else {
        Py_DECREF(shape);
    }
    /* the labels that move, the last fastest: a tight loop along it, an odometer over the
     * others */
    Py_ssize_t moving[MAX_LABELS], n_moving = 0;
    for (Py_ssize_t u = 0; u < n_labels; u++)
        if (seen[u] && size[u] > 1) moving[n_moving++] = u;
    Py_ssize_t inner = n_moving > 0 ? moving[--n_moving] : -1;
    Py_ssize_t length = inner >= 0 ? size[inner] : 1;
    Py_ssize_t inner_stride[32], inner_out = inner >= 0 ? out_stride[inner] : 0;
    for (Py_ssize_t k = 0; k < m; k++) {
        offset[k] = 0;
        inner_stride[k] = inner >= 0 ? strides[k][inner] : 0;
    }
    for (Py_ssize_t d = 0; d < n_moving; d++) idx[d] = 0;
    Py_ssize_t at = 0;
    for (;;) {
        if (m == 2) {
            const double *x = base[0] + offset[0], *y = base[1] + offset[1];
            Py_ssize_t sx = inner_stride[0], sy = inner_stride[1];
            if (inner_out == 0) {
                double sum = 0.0;
                for (Py_ssize_t i = 0; i < length; i++) sum += x[i * sx] * y[i * sy];
                out[at] += sum;
            } else {
                for (Py_ssize_t i = 0; i < length; i++) out[at + i * inner_out] += x[i * sx] * y[i * sy];
            }
        } else {
            for (Py_ssize_t i = 0; i < length; i++) {
                double product = base[0][offset[0] + i * inner_stride[0]];
                for (Py_ssize_t k = 1; k < m; k++) product *= base[k][offset[k] + i * inner_stride[k]];
                out[at + i * inner_out] += product;
            }
        }
        Py_ssize_t d = n_moving - 1;
        for (; d >= 0; d--) {
            Py_ssize_t u = moving[d];
            if (++idx[d] < size[u]) {
                for (Py_ssize_t k = 0; k < m; k++) offset[k] += strides[k][u];
                at += out_stride[u];
                break;
            }
            idx[d] = 0;
            for (Py_ssize_t k = 0; k < m; k++) offset[k] -= strides[k][u] * (size[u] - 1);
            at -= out_stride[u] * (size[u] - 1);
        }
        if (d < 0) break;
    }
    if (have_out) {
        PyBuffer_Release(&out_view);
    } else {
        PyObject *value = PyFloat_FromDouble(total_scalar);
        if (value != NULL) {
            result = PyObject_CallOneArg(numpy_float64, value);
            Py_DECREF(value);
        }
    }
done:
    for (Py_ssize_t k = 0; k < n_views; k++) PyBuffer_Release(&views[k]);
    return result;
}

static PyMethodDef methods[] = {
    {"eliminate", eliminate, METH_VARARGS,
     "eliminate(scopes, labels, output, card, extra, constant, limit) -> "
     "(path, kept, records, total) | None"},
    {"restrict", restrict_order, METH_VARARGS,
     "restrict(scopes, output, positions, weights, bound) -> labels | None"},
    {"min_weight", min_weight, METH_VARARGS,
     "min_weight(scopes, output, card, weights) -> (rank, bound)"},
    {"contract", contract, METH_VARARGS,
     "contract(a, labels_a, b, labels_b, ..., labels_out): numpy's einsum in sub-list form, "
     "small float64 products computed here"},
    {"prune", prune, METH_VARARGS,
     "prune(table, targets, evidence, kind, priors) -> (kept, replaced, dropped)"},
    {"step", step, METH_VARARGS,
     "step(chosen, kept, union, large, results, steps, n_inputs, constant) -> operand"},
    {"emit", emit, METH_VARARGS,
     "emit(live, path, kept, records, results, steps, n_inputs, blas_above, split_above, "
     "max_operands, max_entries, constant, wide) -> None"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_orders",
    "Elimination orders of a pattern's first question, compiled (see _orders.c).", -1, methods,
};

PyMODINIT_FUNC PyInit__orders(void) {
    PyObject *numpy = PyImport_ImportModule("numpy");
    if (numpy == NULL) return NULL;
    numpy_empty = PyObject_GetAttrString(numpy, "empty");
    numpy_float64 = PyObject_GetAttrString(numpy, "float64");
    Py_DECREF(numpy);
    /* numpy's C einsum, without the dispatch of numpy.einsum (numpy 2, then numpy 1) */
    const char *places[] = {"numpy._core.multiarray", "numpy.core.multiarray"};
    for (int k = 0; k < 2 && numpy_einsum == NULL; k++) {
        PyObject *place = PyImport_ImportModule(places[k]);
        if (place != NULL) {
            numpy_einsum = PyObject_GetAttrString(place, "c_einsum");
            Py_DECREF(place);
        }
        PyErr_Clear();
    }
    if (numpy_einsum == NULL) {
        PyObject *numpy_again = PyImport_ImportModule("numpy");
        if (numpy_again == NULL) return NULL;
        numpy_einsum = PyObject_GetAttrString(numpy_again, "einsum");
        Py_DECREF(numpy_again);
    }
    if (numpy_empty == NULL || numpy_float64 == NULL || numpy_einsum == NULL) return NULL;
    return PyModule_Create(&module);
}
