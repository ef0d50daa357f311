/* The co-simulation master's inner loop in C: the one-pass schemes (no iteration) of nnfmu/cosim/master.py over FMI 2
 * calls, step for step the same arithmetic, so a run gives the same numbers as the Python loop without a foreign call
 * per transfer. Python prepares everything (buffers, value references, function pointers taken from the FMUs' shared
 * libraries) and calls nn_cosim_steps once per block of steps; a failing call stops the block and is described in
 * nn_failure for Python to report. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__GNUC__)
#define NN_EXPORT __attribute__((visibility("default")))
#else
#define NN_EXPORT
#endif

#define NN_WARNING 1 /* fmi2Warning: a status above it means the call failed */

typedef int (*nn_transfer)(void *instance, const uint32_t *references, size_t n, double *values);
typedef int (*nn_set_slopes)(void *instance, const uint32_t *references, size_t n, const int *orders,
                             const double *values);
typedef int (*nn_do_step)(void *instance, double t, double h, int no_prior_state);

/* One element: its coupled inputs are gathered from `sources` (positions in the values row) into the first
 * n_coupled entries of `inputs`; the driven element's drive inputs follow them. Its outputs land at values + span_start. */
typedef struct {
    void *instance;
    nn_transfer set_real;
    nn_transfer get_real;
    nn_set_slopes set_slopes; /* NULL: the element takes no slopes */
    nn_do_step do_step;
    const uint32_t *input_references;
    double *inputs;
    int64_t n_coupled;
    int64_t n_driven;
    const int64_t *sources;
    const uint32_t *slope_references;
    const int *slope_orders;
    double *slopes;
    const uint32_t *output_references;
    int64_t n_outputs;
    int64_t span_start;
    int64_t is_driven;
    int64_t feedthrough;
    const double *in_scale; /* units: input = value * in_scale + in_offset before each set (NULL: as they are) */
    const double *in_offset;
    const double *out_scale; /* row value = output * out_scale + out_offset after each get (NULL: as they are) */
    const double *out_offset;
} nn_element;

/* Elements in stepping order; group g is elements [group_starts[g], group_starts[g + 1]). */
typedef struct {
    nn_element *elements;
    int64_t n_elements;
    const int64_t *group_starts;
    int64_t n_groups;
    const int64_t *refreshed; /* indices of the elements refreshed after the pass */
    int64_t n_refreshed;
    int64_t n_values;
    int64_t n_drive;
    int64_t linear_extrapolation;
    int64_t gauss_seidel;
    double *values; /* written by the FMUs */
    double *now;
    double *before;
    double *estimate;
    double *fresh; /* Gauss-Seidel: the estimate with the outputs of the elements stepped so far */
} nn_plan;

/* Which call failed: the step index, the element, the call (see NN_CALL_*) and its status. */
typedef struct {
    int64_t step;
    int64_t element;
    int64_t call;
    int64_t status;
} nn_failure;

enum { NN_CALL_SET = 0, NN_CALL_SLOPES = 1, NN_CALL_STEP = 2, NN_CALL_GET = 3, NN_CALL_REFRESH_SET = 4,
       NN_CALL_REFRESH_GET = 5 };

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
    if (status <= NN_WARNING) return 0;
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
static int one_step(const nn_plan *plan, int64_t n, double t0, double h, const double *drive, const double *end,
                    nn_failure *failure) {
    int64_t g, k, i, n_values = plan->n_values;
    double t = t0 + (double)n * h;
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

/* Steps first .. last - 1; drive holds the drive at t_first .. t_last (n_drive values each), rows receives the values
 * row after each step. Returns 0, or 1 with `failure` filled (the buffers then hold the failing step's values). */
NN_EXPORT int nn_cosim_steps(const nn_plan *plan, int64_t first, int64_t last, double t0, double h,
                             const double *drive, double *rows, nn_failure *failure) {
    int64_t n;
    for (n = first; n < last; n++) {
        const double *at = drive + (n - first) * plan->n_drive;
        if (one_step(plan, n, t0, h, at, at + plan->n_drive, failure)) return 1;
        memcpy(rows + (n - first) * plan->n_values, plan->values, (size_t)plan->n_values * sizeof(double));
    }
    return 0;
}
