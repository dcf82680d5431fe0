/* The compiled core of the Bayesian-network engine's planner (bayesmap.bn._orders).
 *
 * A pattern's first ("cold") question prunes the network, walks an elimination order over
 * the pattern's factors and assembles a program of sum-product steps; in Python that was a
 * few thousand interpreter steps per question, most of what a cold question cost beside
 * the arithmetic. The Python planner (bayesmap.bn.plans, bayesmap.bn.elimination) keeps
 * every decision and calls these for the mechanical parts:
 *
 *   prune(table, targets, evidence, kind, priors)
 *       Which CPTs a question's plan keeps, over the network's variable sets as rows of
 *       64-bit words (Compiled.mask_table).
 *   restrict(scopes, output, positions, weights, bound)
 *       The labels a plan sums, in the network-wide elimination order.
 *   eliminate(scopes, labels, output, card, extra, constant, limit)
 *       Sum `labels` out in this order, each with the factors then holding it, then join
 *       what is left into `output` (bayesmap.bn.plans.order_steps documents the deferral of
 *       steps that join evidence-dependent factors, `constant`, and the cost bound
 *       `limit`). Returns (path, kept, records, total), or None once the steps cost more
 *       than `limit` multiply-adds.
 *   min_weight(scopes, output, card, weights)
 *       The greedy min-weight elimination order of the factors' interaction graph (Koller &
 *       Friedman 2009, section 9.4.3.2): each label's position, and the sum of the weights
 *       of its eliminations; `weights`, a dict or None, receives each label's weight.
 *   step(...), emit(...)
 *       The steps of a compiled sum-product program (SumProgram.extend): einsum sub-lists
 *       numbered, constant steps looked up in the memo.
 *   contract(a, labels_a, ..., labels_out)
 *       numpy's einsum in sub-list form, small float64 products summed here.
 *
 * Labels are Python ints: variable ids (>= 0, sized by `card`) and other labels (< 0, the
 * case axis of a batch, sized by the dict `extra`). Entries and weights are unsigned 64-bit
 * integers that saturate at 2**64 - 1: a step that large is 2**37 times over the largest
 * table bayesmap will build (elimination.MAX_STEP_ENTRIES), so no question that can be
 * answered is ordered differently from exact integers.
 */
#include "orders.h"

static PyMethodDef methods[] = {
    {"eliminate", orders_eliminate, METH_VARARGS,
     "eliminate(scopes, labels, output, card, extra, constant, limit) -> "
     "(path, kept, records, total) | None"},
    {"restrict", orders_restrict_order, METH_VARARGS,
     "restrict(scopes, output, positions, weights, bound) -> labels | None"},
    {"min_weight", orders_min_weight, METH_VARARGS,
     "min_weight(scopes, output, card, weights) -> (rank, bound)"},
    {"contract", orders_contract, METH_VARARGS,
     "contract(a, labels_a, b, labels_b, ..., labels_out): numpy's einsum in sub-list form, "
     "small float64 products computed here"},
    {"prune", orders_prune, METH_VARARGS,
     "prune(table, targets, evidence, kind, priors) -> (kept, replaced, dropped)"},
    {"step", orders_step, METH_VARARGS,
     "step(chosen, kept, union, large, results, steps, n_inputs, constant) -> operand"},
    {"emit", orders_emit, METH_VARARGS,
     "emit(live, path, kept, records, results, steps, n_inputs, blas_above, split_above, "
     "max_operands, max_entries, constant, wide) -> None"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_orders",
    "The compiled core of the engine's planner (see bayesmap/bn/csrc).", -1, methods,
};

PyMODINIT_FUNC PyInit__orders(void) {
    if (orders_contract_init() < 0) return NULL;
    return PyModule_Create(&module);
}
