/* Small sum-products (contract). */
#include "orders.h"

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

PyObject *orders_contract(PyObject *self, PyObject *args) {
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
                for (Py_ssize_t i = 0; i < length; i++)
                    out[at + i * inner_out] += x[i * sx] * y[i * sy];
            }
        } else {
            for (Py_ssize_t i = 0; i < length; i++) {
                double product = base[0][offset[0] + i * inner_stride[0]];
                for (Py_ssize_t k = 1; k < m; k++)
                    product *= base[k][offset[k] + i * inner_stride[k]];
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

int orders_contract_init(void) {
    PyObject *numpy = PyImport_ImportModule("numpy");
    if (numpy == NULL) return -1;
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
        if (numpy_again == NULL) return -1;
        numpy_einsum = PyObject_GetAttrString(numpy_again, "einsum");
        Py_DECREF(numpy_again);
    }
    return numpy_empty == NULL || numpy_float64 == NULL || numpy_einsum == NULL ? -1 : 0;
}
