/* Which CPTs a question's plan keeps (prune). */
#include "orders.h"

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
static Py_ssize_t read_ids(PyObject *seq, int64_t n, Py_ssize_t **out) {
    PyObject *fast = PySequence_Fast(seq, "variable ids must be a sequence");
    if (fast == NULL) return -1;
    Py_ssize_t m = PySequence_Fast_GET_SIZE(fast);
    *out = PyMem_Malloc(((size_t)m + 1) * sizeof(Py_ssize_t));
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

/* Sort a few ids ascending by key[id] (or by id, with key NULL): an insertion sort. */
static void sort_ids(Py_ssize_t *ids, Py_ssize_t n, const int64_t *key) {
    for (Py_ssize_t i = 1; i < n; i++) {
        Py_ssize_t x = ids[i];
        int64_t kx = key ? key[x] : x;
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
PyObject *orders_prune(PyObject *self, PyObject *args) {
    PyObject *blob, *targets_obj, *evidence_obj;
    int kind, priors;
    if (!PyArg_ParseTuple(args, "OOOip", &blob, &targets_obj, &evidence_obj, &kind, &priors))
        return NULL;
    table_t t;
    if (read_table(blob, &t) < 0) return NULL;
    int64_t W = t.words, n = t.n;
    Py_ssize_t *targets = NULL, *evidence = NULL, *relevant = NULL, *kept = NULL;
    Py_ssize_t *replaced = NULL, *dropped = NULL;
    uint64_t *work = NULL, *scope = NULL;
    PyObject *result = NULL;
    Py_ssize_t n_targets = read_ids(targets_obj, n, &targets);
    Py_ssize_t n_evidence = n_targets < 0 ? -1 : read_ids(evidence_obj, n, &evidence);
    if (n_targets < 0 || n_evidence < 0) goto done;
    /* working rows: evidence, its lineage, targets, relevant, skip, covered, reached, before */
    work = PyMem_Calloc((size_t)(8 * W), sizeof(uint64_t));
    relevant = PyMem_Malloc(((size_t)n + n_evidence + 2) * sizeof(Py_ssize_t));
    kept = PyMem_Malloc(((size_t)n + n_evidence + 2) * sizeof(Py_ssize_t));
    replaced = PyMem_Malloc(((size_t)n + 1) * sizeof(Py_ssize_t));
    dropped = PyMem_Malloc(((size_t)n_evidence + 1) * sizeof(Py_ssize_t));
    if (!work || !relevant || !kept || !replaced || !dropped) {
        PyErr_NoMemory();
        goto done;
    }
    uint64_t *ev = work, *ev_lineage = work + W, *tm = work + 2 * W, *r = work + 3 * W;
    uint64_t *skip = work + 4 * W, *covered = work + 5 * W, *reached = work + 6 * W;
    uint64_t *before = work + 7 * W;
    for (Py_ssize_t k = 0; k < n_evidence; k++) {
        Py_ssize_t v = evidence[k];
        ev[v / 64] |= (uint64_t)1 << (v % 64);
        for (int64_t j = 0; j < W; j++) ev_lineage[j] |= t.lineage[v * W + j];
    }
    for (Py_ssize_t k = 0; k < n_targets; k++)
        tm[targets[k] / 64] |= (uint64_t)1 << (targets[k] % 64);
    Py_ssize_t n_relevant = 0, n_kept = 0, n_replaced = 0, n_dropped = 0;
    int alone = 0;
    if (priors && n_evidence > 0 && n_targets == 1 && kind == 0) {
        Py_ssize_t v = targets[0];
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
        Py_ssize_t v = relevant[k];
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
        Py_ssize_t v = relevant[k];
        const uint64_t *row = scope + k * W;
        if (filtered && !is_zero(row, W) && !any_and(row, reached, W)) {
            if (BIT(ev, v)) dropped[n_dropped++] = v;
            continue;
        }
        kept[n_kept++] = v;
    }
    sort_ids(dropped, n_dropped, NULL);
    PyObject *kept_tuple = orders_int_tuple(kept, n_kept);
    PyObject *replaced_tuple = orders_int_tuple(replaced, n_replaced);
    PyObject *dropped_tuple = orders_int_tuple(dropped, n_dropped);
    if (kept_tuple && replaced_tuple && dropped_tuple)
        result = PyTuple_Pack(3, kept_tuple, replaced_tuple, dropped_tuple);
    Py_XDECREF(kept_tuple);
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
