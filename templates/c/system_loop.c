/* system_loop.c: the outer loop of `nnfmu cosim --engine compiled` (nnfmu/cosim/container/engine.py, loaded through
 * ctypes): a system FMU (`nnfmu system build`, inner step = the communication step) stepped over a block of steps
 * as a plain fixed-step master would, but without a foreign call per FMI call: per step the drive at t_n, its slopes
 * toward t_{n+1}, doStep(t_n, h), every output. The instance and its functions come from fmpy, which instantiated
 * and initialised the FMU. */
#include <stddef.h>
#include <stdint.h>

#if defined(__GNUC__)
#define NS_EXPORT __attribute__((visibility("default")))
#else
#define NS_EXPORT
#endif

#define NS_WARNING 1 /* fmi2Warning: a status above it means the call failed */

typedef int (*ns_transfer)(void *instance, const uint32_t *references, size_t n, double *values);
typedef int (*ns_set_slopes)(void *instance, const uint32_t *references, size_t n, const int *orders,
                             const double *values);
typedef int (*ns_do_step)(void *instance, double t, double h, int no_prior_state);

/* The system FMU as fmpy opened it, its inputs (the drive) and outputs by value reference. */
typedef struct {
    void *instance;
    ns_transfer set_real;
    ns_transfer get_real;
    ns_set_slopes set_slopes;
    ns_do_step do_step;
    const uint32_t *input_references;
    int64_t n_inputs;
    const int *orders; /* 1 per input */
    const uint32_t *output_references;
    int64_t n_outputs;
    double *slopes; /* n_inputs */
} ns_driver;

/* Where a block stopped: the step index, the call (0 set inputs, 1 set slopes, 2 doStep, 3 get outputs), status. */
typedef struct {
    int64_t step;
    int64_t call;
    int64_t status;
} ns_failure;

#define NS_CALL(which, expression)                                                                                    \
    do {                                                                                                              \
        int status_ = (expression);                                                                                   \
        if (status_ > NS_WARNING) {                                                                                   \
            failure->step = n;                                                                                        \
            failure->call = (which);                                                                                  \
            failure->status = status_;                                                                                \
            return status_;                                                                                           \
        }                                                                                                             \
    } while (0)

/* Steps first .. last - 1 at t_n = t0 + n h: `drive` holds the drive at t_first .. t_last (rows of n_inputs), `rows`
 * receives the outputs at t_{first+1} .. t_last (rows of n_outputs). Returns 0, or the failing call's status with
 * `failure` filled in. */
NS_EXPORT int ns_drive_steps(const ns_driver *d, int64_t first, int64_t last, double t0, double h,
                             const double *drive, double *rows, ns_failure *failure) {
    int64_t n, i;
    const size_t n_in = (size_t)d->n_inputs;
    for (n = first; n < last; n++) {
        const double *now = drive + (n - first) * d->n_inputs;
        const double *end = now + d->n_inputs;
        if (n_in > 0) {
            for (i = 0; i < d->n_inputs; i++) d->slopes[i] = (end[i] - now[i]) / h;
            NS_CALL(0, d->set_real(d->instance, d->input_references, n_in, (double *)now));
            NS_CALL(1, d->set_slopes(d->instance, d->input_references, n_in, d->orders, d->slopes));
        }
        NS_CALL(2, d->do_step(d->instance, t0 + (double)n * h, h, 1));
        NS_CALL(3, d->get_real(d->instance, d->output_references, (size_t)d->n_outputs,
                               rows + (n - first) * d->n_outputs));
    }
    return 0;
}
