/* Shared by the compiled core's sources (see module.c): saturating counts, growable arrays
 * and the functions module.c puts in the module. */
#ifndef BAYESMAP_ORDERS_H
#define BAYESMAP_ORDERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t count_t;

static inline count_t mul_sat(count_t a, count_t b) {
    count_t r;
    return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
}

static inline count_t add_sat(count_t a, count_t b) {
    count_t r;
    return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
}

/* A growable array of Py_ssize_t. */
typedef struct {
    Py_ssize_t *a;
    Py_ssize_t n, cap;
} vec;

static inline int vec_push(vec *v, Py_ssize_t x) {
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

static inline void vec_remove(vec *v, Py_ssize_t x) {
    for (Py_ssize_t k = 0; k < v->n; k++) {
        if (v->a[k] == x) {
            memmove(v->a + k, v->a + k + 1, (size_t)(v->n - k - 1) * sizeof(Py_ssize_t));
            v->n--;
            return;
        }
    }
}

/* The smallest and largest label of `scopes` and `output` (sequences of ints); walk.c. */
int orders_read_range(PyObject *scopes_fast, PyObject *output_fast, long *lo, long *hi);
/* A tuple of Python ints; walk.c. */
PyObject *orders_int_tuple(const Py_ssize_t *xs, Py_ssize_t n);

PyObject *orders_eliminate(PyObject *self, PyObject *args);      /* walk.c */
PyObject *orders_restrict_order(PyObject *self, PyObject *args); /* walk.c */
PyObject *orders_min_weight(PyObject *self, PyObject *args);     /* rank.c */
PyObject *orders_prune(PyObject *self, PyObject *args);          /* prune.c */
PyObject *orders_step(PyObject *self, PyObject *args);           /* steps.c */
PyObject *orders_emit(PyObject *self, PyObject *args);           /* steps.c */
PyObject *orders_contract(PyObject *self, PyObject *args);       /* contract.c */
int orders_contract_init(void);                                  /* contract.c: numpy's functions */

#endif
