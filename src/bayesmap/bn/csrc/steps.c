/* The steps of a compiled sum-product program (step, emit). */
#include "orders.h"

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

PyObject *orders_step(PyObject *self, PyObject *args) {
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
PyObject *orders_emit(PyObject *self, PyObject *args) {
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
