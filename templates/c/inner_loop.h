/* inner_loop.h: the co-simulation master's one-pass schemes in C (inner_loop.c), shared by nnfmu's Python master
 * (loaded through ctypes, nnfmu/cosim/inner_loop.py) and by the system FMU's master (system_fmu.c, `nnfmu system
 * build`), which fills the same plan from its generated configuration. */
#ifndef NN_INNER_LOOP_H
#define NN_INNER_LOOP_H

#include <stddef.h>
#include <stdint.h>

/* Exported for ctypes; a system FMU compiles the loop with NN_LOOP_HIDDEN so only its FMI functions are visible. */
#if defined(__GNUC__) && !defined(NN_LOOP_HIDDEN)
#define NN_EXPORT __attribute__((visibility("default")))
#else
#define NN_EXPORT
#endif

#define NN_LOOP_WARNING 1 /* fmi2Warning: a status above it means the call failed */

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

/* Steps first .. last - 1 from t = t0 + n h; drive holds the drive at t_first .. t_last (n_drive values each), rows
 * receives the values row after each step. Returns 0, or 1 with `failure` filled (the buffers then hold the failing
 * step's values). */
NN_EXPORT int nn_cosim_steps(const nn_plan *plan, int64_t first, int64_t last, double t0, double h,
                             const double *drive, double *rows, nn_failure *failure);

/* One communication step with index n (n = 0: nothing to extrapolate from yet) from t to t + h, the drive at t and
 * at t + h (`end`); 0, or 1 with `failure` filled. */
NN_EXPORT int nn_cosim_step(const nn_plan *plan, int64_t n, double t, double h, const double *drive,
                            const double *end, nn_failure *failure);

/* The refresh alone: inputs at the current communication point (drive `end`) for the elements with feedthrough,
 * then their outputs again; what initialisation ends with. 0, or 1 with `failure` filled (step -1). */
NN_EXPORT int nn_cosim_refresh(const nn_plan *plan, const double *end, nn_failure *failure);

#endif /* NN_INNER_LOOP_H */
