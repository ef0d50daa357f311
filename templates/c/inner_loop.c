/* The co-simulation master's inner loop in C: the one-pass schemes (no iteration) of nnfmu/cosim/master.py over FMI 2
 * calls, step for step the same arithmetic, so a run gives the same numbers as the Python loop without a foreign call
 * per transfer. Python prepares everything (buffers, value references, function pointers taken from the FMUs' shared
 * libraries) and calls nn_cosim_steps once per block of steps; a failing call stops the block and is described in
 * nn_failure for Python to report. The system FMU (`nnfmu system build`) steps the same loop from its own master. */
#include <string.h>

#include "inner_loop.h"

/* The element's inputs in its own units, then one set (master.py: RealBlock.set with a conversion). */
static int set_real(const nn_element *e, int64_t step, int64_t index, int64_t call, nn_failure *failure);

/* What the FMU wrote into its span, in the master's units (master.py: RealBlock.get with a conversion). */
static void outputs_in_row_units(const nn_element *e, double *span) {
    int64_t i;
    if (e->out_scale == NULL) return;
    for (i = 0; i < e->n_outputs; i++) {
        span[i] *= e->out_scale[i];
        span[i] += e->out_offset[i];
    }
}

static int failed(nn_failure *failure, int64_t step, int64_t element, int64_t call, int status) {
    if (status <= NN_LOOP_WARNING) return 0;
    failure->step = step;
    failure->element = element;
    failure->call = call;
    failure->status = status;
    return 1;
}

static int set_real(const nn_element *e, int64_t step, int64_t index, int64_t call, nn_failure *failure) {
    int64_t i, n_inputs = e->n_coupled + e->n_driven;
    if (e->in_scale != NULL) {
        for (i = 0; i < n_inputs; i++) {
            e->inputs[i] *= e->in_scale[i];
            e->inputs[i] += e->in_offset[i];
        }
    }
    return failed(failure, step, index, call, e->set_real(e->instance, e->input_references, (size_t)n_inputs,
                                                          e->inputs));
}

/* The element's inputs before its step (master.py: _System._set_inputs, scheme not plain). */
static int set_inputs(const nn_plan *plan, int64_t index, const double *source, const double *drive,
                      const double *end, double h, int64_t step, nn_failure *failure) {
    nn_element *e = &plan->elements[index];
    int64_t i, n = e->n_coupled;
    size_t n_inputs = (size_t)(e->n_coupled + e->n_driven);
    if (n_inputs == 0) return 0;
    if (e->feedthrough) {
        if (plan->n_refreshed == 0) {
            for (i = 0; i < n; i++) e->inputs[i] = plan->now[e->sources[i]];
            if (e->is_driven) memcpy(e->inputs + n, drive, (size_t)e->n_driven * sizeof(double));
            if (set_real(e, step, index, NN_CALL_SET, failure)) return 1;
        }
        if (e->set_slopes != NULL) {
            for (i = 0; i < n; i++) e->slopes[i] = (source[e->sources[i]] - plan->now[e->sources[i]]) / h;
            for (i = 0; i < e->n_driven; i++) e->slopes[n + i] = (end[i] - drive[i]) / h;
            if (e->in_scale != NULL)
                for (i = 0; i < (int64_t)n_inputs; i++) e->slopes[i] *= e->in_scale[i];
            return failed(failure, step, index, NN_CALL_SLOPES,
                          e->set_slopes(e->instance, e->slope_references, n_inputs, e->slope_orders, e->slopes));
        }
        return 0;
    }
    if (e->is_driven) {
        for (i = 0; i < n; i++) e->inputs[i] = 0.5 * (plan->now[e->sources[i]] + source[e->sources[i]]);
        for (i = 0; i < e->n_driven; i++) e->inputs[n + i] = 0.5 * (drive[i] + end[i]);
    } else {
        for (i = 0; i < n; i++) e->inputs[i] = source[e->sources[i]];
    }
    return set_real(e, step, index, NN_CALL_SET, failure);
}

/* Inputs at t_{n+1} for the elements with feedthrough, then their outputs again (master.py: _System.refresh). */
static int refresh(const nn_plan *plan, const double *end, int64_t step, nn_failure *failure) {
    int64_t r, i;
    for (r = 0; r < plan->n_refreshed; r++) {
        int64_t index = plan->refreshed[r];
        nn_element *e = &plan->elements[index];
        for (i = 0; i < e->n_coupled; i++) e->inputs[i] = plan->values[e->sources[i]];
        if (e->is_driven) memcpy(e->inputs + e->n_coupled, end, (size_t)e->n_driven * sizeof(double));
        if (set_real(e, step, index, NN_CALL_REFRESH_SET, failure)) return 1;
        if (failed(failure, step, index, NN_CALL_REFRESH_GET,
                   e->get_real(e->instance, e->output_references, (size_t)e->n_outputs,
                               plan->values + e->span_start)))
            return 1;
        outputs_in_row_units(e, plan->values + e->span_start);
    }
    return 0;
}

/* One communication step n from t = t0 + n h (master.py: _System.step with no iterations, and exchange). */
static int one_step(const nn_plan *plan, int64_t n, double t, double h, const double *drive, const double *end,
                    nn_failure *failure) {
    int64_t g, k, i, n_values = plan->n_values;
    double *source = plan->gauss_seidel ? plan->fresh : plan->estimate;
    if (plan->linear_extrapolation && n > 0) {
        for (i = 0; i < n_values; i++) plan->estimate[i] = 2.0 * plan->now[i] - plan->before[i];
    } else {
        memcpy(plan->estimate, plan->now, (size_t)n_values * sizeof(double));
    }
    if (plan->gauss_seidel) memcpy(plan->fresh, plan->estimate, (size_t)n_values * sizeof(double));
    for (g = 0; g < plan->n_groups; g++) {
        int64_t first = plan->group_starts[g], last = plan->group_starts[g + 1];
        for (k = first; k < last; k++)
            if (set_inputs(plan, k, source, drive, end, h, n, failure)) return 1;
        for (k = first; k < last; k++) {
            nn_element *e = &plan->elements[k];
            if (failed(failure, n, k, NN_CALL_STEP, e->do_step(e->instance, t, h, 1))) return 1;
        }
        for (k = first; k < last; k++) {
            nn_element *e = &plan->elements[k];
            double *span = plan->values + e->span_start;
            if (failed(failure, n, k, NN_CALL_GET, e->get_real(e->instance, e->output_references,
                                                               (size_t)e->n_outputs, span)))
                return 1;
            outputs_in_row_units(e, span);
            if (plan->gauss_seidel) memcpy(plan->fresh + e->span_start, span, (size_t)e->n_outputs * sizeof(double));
        }
    }
    if (refresh(plan, end, n, failure)) return 1;
    memcpy(plan->before, plan->now, (size_t)n_values * sizeof(double));
    memcpy(plan->now, plan->values, (size_t)n_values * sizeof(double));
    return 0;
}

NN_EXPORT int nn_cosim_steps(const nn_plan *plan, int64_t first, int64_t last, double t0, double h,
                             const double *drive, double *rows, nn_failure *failure) {
    int64_t n;
    for (n = first; n < last; n++) {
        const double *at = drive + (n - first) * plan->n_drive;
        if (one_step(plan, n, t0 + (double)n * h, h, at, at + plan->n_drive, failure)) return 1;
        memcpy(rows + (n - first) * plan->n_values, plan->values, (size_t)plan->n_values * sizeof(double));
    }
    return 0;
}

NN_EXPORT int nn_cosim_step(const nn_plan *plan, int64_t n, double t, double h, const double *drive,
                            const double *end, nn_failure *failure) {
    return one_step(plan, n, t, h, drive, end, failure);
}

NN_EXPORT int nn_cosim_refresh(const nn_plan *plan, const double *end, nn_failure *failure) {
    return refresh(plan, end, -1, failure);
}
