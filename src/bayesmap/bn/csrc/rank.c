/* The greedy min-weight elimination order (min_weight). */
#include "orders.h"

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

PyObject *orders_min_weight(PyObject *self, PyObject *args) {
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
    if (orders_read_range(scopes_fast, output_fast, &lo, &hi) < 0) goto done;
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
