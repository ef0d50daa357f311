/* nn_fmu.h: the FMI-version-independent core of every nnfmu FMU.
 *
 * Written once for nnfmu and identical in every FMU: the FMI 2 and FMI 3 entry points (fmi2Functions.c,
 * fmi3Functions.c) check their arguments and translate to these functions. What differs between FMUs lives in the
 * generated config.h (counts, value references, port-to-graph maps, sample period, envelope, initial state) and in
 * graph.c/graph.h (the network's step function `nn_graph_run`).
 */
#ifndef NN_FMU_H
#define NN_FMU_H

#include <stddef.h>
#include <stdint.h>

#include "config.h"
#include "graph.h"

/* Same order and values as fmi2Status and fmi3Status, so the glue can cast. */
typedef enum { NN_OK = 0, NN_WARNING = 1, NN_DISCARD = 2, NN_ERROR = 3, NN_FATAL = 4 } NNStatus;

/* Modes of the FMI state machine, as bits so that a call can name every mode it is allowed in. */
typedef enum {
    NN_INSTANTIATED = 1u << 0,
    NN_INITIALIZATION = 1u << 1,
    NN_STEPPING = 1u << 2,
    NN_TERMINATED = 1u << 3,
    NN_FAILED = 1u << 4
} NNMode;

#define NN_ANY_MODE (NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED | NN_FAILED)

/* Log categories; their names (nn_category_name) are listed in modelDescription.xml. */
typedef enum { NN_LOG_EVENTS = 0, NN_LOG_WARNING = 1, NN_LOG_ERROR = 2, NN_N_CATEGORIES = 3 } NNCategory;

/* Everything that evolves during a simulation; an FMU state is a copy of this struct.
 *
 * The `*_before` fields keep what held before the latest sample, so that an FMU whose inputs are interpolated
 * (NN_INTERPOLATES_INPUTS) can evaluate its latest sample again when the master sets new inputs at that sample's
 * time (docs/fmu.md). */
typedef struct {
    double input[NN_INPUT_CAPACITY];          /* values set by the master */
    double input_slope[NN_INPUT_CAPACITY];    /* [unit/s] FMI 2 input derivatives for the coming step (else 0) */
    double knot[NN_INPUT_CAPACITY];           /* inputs of the latest sample (the end of its interval) */
    double knot_before[NN_INPUT_CAPACITY];    /* inputs of the sample before it (the start of that interval) */
    double output[NN_OUTPUT_CAPACITY];        /* filtered, gained outputs of the latest sample */
    double output_before[NN_OUTPUT_CAPACITY];
    double state[NN_STATE_CAPACITY];          /* graph state (delay line, recurrent state) before the next sample */
    double state_before[NN_STATE_CAPACITY];   /* graph state before the latest sample */
    int outside[NN_INPUT_CAPACITY];           /* per input: the latest sample lay outside the training envelope */
    int outside_before[NN_INPUT_CAPACITY];
    int extrapolating;                        /* any input of the latest sample outside the training envelope */
    int inputs_set;                           /* an input was set since the latest sample was evaluated */
    int mode;                                 /* the NNMode the state was saved in */
    double filter_cutoff;                     /* [Hz], 0 = filter off */
    double output_gain;                       /* [1] */
    double filter_weight;                     /* [1] the filter's weight of the latest evaluation's value */
    double start_time;                        /* [s] t_start: sample k falls at t_start + k*T */
    double time;                              /* [s] current communication point */
    double elapsed;                           /* [s] time since t_start, the sum of the step sizes */
    double elapsed_carry;                     /* [s] what summing the step sizes lost (Kahan) */
    double evaluated_at;                      /* [s] elapsed time at which the outputs were last evaluated */
    double alpha;                             /* [1] where in its sample period the latest evaluation fell (0: at it) */
    uint64_t samples_done;                    /* samples evaluated so far; the next one has index samples_done */
} NNModelData;

/* Hands a formatted message to the FMI-version-specific logger callback kept by the glue. */
typedef void NNLogFunction(const void *instance, NNStatus status, const char *category, const char *message);

/* The master's logger, stored as a generic function pointer; the glue casts it back to its own type. */
typedef void (*NNCallback)(void);

typedef struct {
    NNModelData data;
    char *name;
    NNMode mode;
    NNLogFunction *log;      /* the glue's adapter that calls `logger` */
    NNCallback logger;       /* the master's logger callback (may be NULL) */
    void *environment;       /* the master's environment pointer, passed back to its logger */
    int logging_on;
    int category_on[NN_N_CATEGORIES];
    int preview_stale;       /* inputs or parameters changed since the Initialization Mode preview */
    double graph_in[NN_N_IN];
    double graph_out[NN_N_OUT];
} NNInstance;

NNInstance *nn_instantiate(const char *name, const char *token, NNLogFunction *log, NNCallback logger,
                           void *environment, int logging_on);
void nn_free(NNInstance *instance);
void nn_reset(NNInstance *instance);

const char *nn_category_name(NNCategory category);
NNStatus nn_set_debug_logging(NNInstance *instance, int logging_on, size_t n_categories,
                              const char *const categories[]);
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
void nn_log(const NNInstance *instance, NNStatus status, NNCategory category, const char *format, ...);

/* What nn_allowed and nn_check_array log when they refuse a call; they return 0. */
int nn_refuse_mode(NNInstance *instance, const char *function);
int nn_refuse_null(const NNInstance *instance, const char *function, size_t n, const char *what);

/* 1 if `instance` may be used in one of the `allowed` modes, else logs why not (naming `function`) and returns 0.
 * Inline, as nn_check_array: every FMI call of every step makes these checks. */
static inline int nn_allowed(NNInstance *instance, const char *function, unsigned allowed) {
    return (instance->mode & allowed) ? 1 : nn_refuse_mode(instance, function);
}

/* 1 unless `array` is NULL while `n` values are asked for, else logs which (naming `function`) and returns 0. */
static inline int nn_check_array(const NNInstance *instance, const char *function, const void *array, size_t n,
                                 const char *what) {
    return (n == 0 || array) ? 1 : nn_refuse_null(instance, function, n, what);
}

NNStatus nn_get_real(NNInstance *instance, unsigned vr, double *value);
NNStatus nn_set_real(NNInstance *instance, unsigned vr, double value);
/* Get or set `n` Real variables in order; the first refused value reference ends the call with its status. */
NNStatus nn_get_reals(NNInstance *instance, const unsigned vr[], size_t n, double value[]);
NNStatus nn_set_reals(NNInstance *instance, const unsigned vr[], size_t n, const double value[]);
NNStatus nn_get_boolean(NNInstance *instance, unsigned vr, int *value);
/* FMI 2 input derivatives of order 1 (the slope of each input over the coming step), for interpolating FMUs. */
NNStatus nn_set_input_slopes(NNInstance *instance, const unsigned vr[], size_t n, const int order[],
                             const double value[]);
NNStatus nn_refuse_type(const NNInstance *instance, const char *function, const char *type, unsigned vr);

/* The directional derivative d(unknowns)/d(knowns) * seed of the FMU's outputs with respect to its inputs at the
 * current inputs and state (docs/fmu.md): unknowns must be Real outputs, knowns inputs, else an error naming the
 * value reference; `function` names the FMI call in messages. An FMU whose graph has no derivative (NN_HAS_JVP 0)
 * refuses every call. */
NNStatus nn_directional_derivative(NNInstance *instance, const char *function, const unsigned unknowns[],
                                   size_t n_unknowns, const unsigned knowns[], size_t n_knowns, const double seed[],
                                   double sensitivity[]);

/* FMI 2 SetupExperiment: the start time (finite) becomes the instance's time too, so that a state saved before
 * initialisation is one DeserializeFMUstate accepts. */
NNStatus nn_setup_experiment(NNInstance *instance, double start_time);
NNStatus nn_enter_initialization(NNInstance *instance, double start_time);
NNStatus nn_exit_initialization(NNInstance *instance);
NNStatus nn_do_step(NNInstance *instance, double current_time, double step_size);

/* An FMU state is an NNModelData copy behind the FMI's opaque state pointer (`void *` in both versions).
 * nn_state_save copies the instance's data into the state *state holds, or into a new one when *state is NULL;
 * nn_state_free frees *state and sets it to NULL. */
NNStatus nn_state_save(NNInstance *instance, void **state);
NNStatus nn_state_restore(NNInstance *instance, const NNModelData *state);
void nn_state_free(void **state);
size_t nn_serialized_size(void);
NNStatus nn_serialize(const NNInstance *instance, const NNModelData *state, unsigned char *buffer, size_t size);
/* Read a serialised state into a new copy that replaces (and frees) *state; *state is kept if the bytes are refused. */
NNStatus nn_deserialize(const NNInstance *instance, const unsigned char *buffer, size_t size, void **state);

#endif /* NN_FMU_H */
