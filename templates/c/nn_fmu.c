/* nn_fmu.c: instance life cycle, logging, variable access, fixed-rate sampling, FMU state and directional
 * derivatives of an nnfmu FMU.
 *
 * Time: sample k falls at t_start + k*T, k counted with an integer and compared with the time elapsed since t_start
 * (the sum of the step sizes), never with absolute time, so a large t_start loses no sample. doStep(t, h) evaluates,
 * in order, every sample with t < t_k <= t + h (within 1e-6*T); the graph state advances only at samples. Sample 0
 * is evaluated when initialisation ends. A graph without a sample period (NN_HAS_SAMPLE_PERIOD 0) is evaluated once
 * at the end of every step. One doStep evaluates at most NN_MAX_SAMPLES_PER_STEP samples.
 *
 * Between samples (a sampled FMU, any step h): a step that ends a fraction alpha of T after the latest sample k
 * (0 < alpha < 1) evaluates the graph once more at its end, with the inputs set before the call and the graph state
 * interpolated linearly between the state sample k was evaluated from and the state after it, (1-alpha) s_k +
 * alpha s_{k+1}: a delay of n samples reads the input n*T ago from the history, filters, operators and rates follow
 * the same way. Nothing advances but the output filter (over the time since the outputs were last evaluated), so
 * at h = k*T the outputs are exactly those of the samples, and at any smaller h they follow the inputs at every
 * communication point instead of holding the latest sample's (docs/fmu.md).
 *
 * Inputs: a sampled FMU (NN_INTERPOLATES_INPUTS 0) gives every sample of a step the inputs set before the call and
 * never evaluates its network when a variable is read. An interpolating FMU (a vehicle) sees each input as linear
 * between samples: a sample's interval ramps from the inputs of the sample before to its own; a sample in a step gets
 * the inputs set before the call plus, on FMI 2, their derivatives times the time from the step's start; inputs set
 * at the time of the latest sample become that sample's inputs, and it is evaluated again (before its outputs are
 * read or the next step is taken), so outputs at a communication point follow the inputs set there; without such a
 * set it keeps the inputs of its step.
 */
#define NN_CONFIG_TABLES
#include "nn_fmu.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define NN_PI 3.14159265358979323846
#define NN_STATE_MAGIC "NNFMUST1"
#define NN_MAGIC_SIZE 8
#define NN_TOKEN_FIELD 64
#define NN_SAMPLE_TOLERANCE 1e-6   /* a sample time within this fraction of T of the step end counts as reached */
#define NN_TIME_TOLERANCE 1e-9     /* relative mismatch allowed between doStep's time and the FMU's time */
#define NN_MAX_SAMPLES_PER_STEP 1000000ULL /* one doStep's work is bounded: more samples are refused */
#define NN_TIME_CONSISTENCY 1e-6   /* how far a state's time may differ from its start time plus elapsed time (relative) */

/* The token must fit the fixed field of the serialised state's header. */
typedef char nn_token_fits_header[(sizeof(NN_INSTANTIATION_TOKEN) <= NN_TOKEN_FIELD) ? 1 : -1];

/* Serialised FMU state: this header followed by the bytes of NNModelData. */
typedef struct {
    char magic[NN_MAGIC_SIZE];
    uint64_t size;
    char token[NN_TOKEN_FIELD];
} NNStateHeader;

static const char *const category_names[NN_N_CATEGORIES] = {"logEvents", "logStatusWarning", "logStatusError"};

const char *nn_category_name(NNCategory category) { return category_names[category]; }

static const char *mode_name(NNMode mode) {
    switch (mode) {
    case NN_INSTANTIATED: return "Instantiated";
    case NN_INITIALIZATION: return "Initialization Mode";
    case NN_STEPPING: return "Step Mode";
    case NN_TERMINATED: return "Terminated";
    case NN_FAILED: return "Error (after a failed call)";
    }
    return "unknown";
}

void nn_log(const NNInstance *instance, NNStatus status, NNCategory category, const char *format, ...) {
    char message[1024];
    va_list args;
    if (!instance->log || !instance->logger) return;
    /* Errors always reach the logger; warnings and events only when logging and their category are on. */
    if (status < NN_ERROR && !(instance->logging_on && instance->category_on[category])) return;
    va_start(args, format);
    vsnprintf(message, sizeof message, format, args);
    va_end(args);
    instance->log(instance, status, category_names[category], message);
}

NNStatus nn_set_debug_logging(NNInstance *instance, int logging_on, size_t n_categories,
                              const char *const categories[]) {
    size_t i;
    int c;
    if (!nn_check_array(instance, "SetDebugLogging", categories, n_categories, "categories")) return NN_ERROR;
    instance->logging_on = logging_on;
    for (c = 0; c < NN_N_CATEGORIES; c++) instance->category_on[c] = (n_categories == 0);
    for (i = 0; i < n_categories; i++) {
        int known = 0;
        for (c = 0; c < NN_N_CATEGORIES; c++) {
            if (categories[i] && strcmp(categories[i], category_names[c]) == 0) {
                instance->category_on[c] = 1;
                known = 1;
            }
        }
        if (!known) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SetDebugLogging: unknown log category '%s' (known: %s, %s, %s)",
                   categories[i] ? categories[i] : "(null)", category_names[0], category_names[1], category_names[2]);
            return NN_ERROR;
        }
    }
    return NN_OK;
}

int nn_refuse_mode(NNInstance *instance, const char *function) {
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s must not be called in state %s", function, mode_name(instance->mode));
    return 0;
}

int nn_refuse_null(const NNInstance *instance, const char *function, size_t n, const char *what) {
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: %s is NULL but %lu values were requested", function, what,
           (unsigned long)n);
    return 0;
}

void nn_reset(NNInstance *instance) {
    NNModelData *d = &instance->data;
    int i;
    memset(d, 0, sizeof *d);
    for (i = 0; i < NN_N_STATE; i++) d->state[i] = nn_state_initial[i];
    d->filter_cutoff = NN_DEFAULT_FILTER_CUTOFF;
    d->output_gain = NN_DEFAULT_OUTPUT_GAIN;
    instance->mode = NN_INSTANTIATED;
    instance->preview_stale = 1;
}

NNInstance *nn_instantiate(const char *name, const char *token, NNLogFunction *log, NNCallback logger,
                           void *environment, int logging_on) {
    NNInstance *instance = (NNInstance *)calloc(1, sizeof(NNInstance));
    size_t length;
    int c;
    if (!instance) return NULL;
    if (!name) name = "";
    length = strlen(name);
    instance->name = (char *)malloc(length + 1);
    if (!instance->name) {
        free(instance);
        return NULL;
    }
    memcpy(instance->name, name, length + 1);
    instance->log = log;
    instance->logger = logger;
    instance->environment = environment;
    instance->logging_on = logging_on;
    for (c = 0; c < NN_N_CATEGORIES; c++) instance->category_on[c] = 1;
    if (!token || strcmp(token, NN_INSTANTIATION_TOKEN) != 0) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "instantiation token '%s' does not match this FMU's '%s'",
               token ? token : "(null)", NN_INSTANTIATION_TOKEN);
        nn_free(instance);
        return NULL;
    }
    nn_reset(instance);
    nn_log(instance, NN_OK, NN_LOG_EVENTS, "instantiated %s (%d inputs, %d outputs, %d state values)",
           NN_MODEL_IDENTIFIER, NN_N_INPUTS, NN_N_OUTPUTS, NN_N_STATE);
    return instance;
}

void nn_free(NNInstance *instance) {
    if (!instance) return;
    free(instance->name);
    free(instance);
}

/* 1 if `vr` lies in [first, first + count); a function so that empty ranges raise no compiler warnings. */
static int in_range(unsigned vr, unsigned first, unsigned count) { return vr >= first && vr - first < count; }

/* Time of sample k after t_start [s]; only meaningful for a graph with a sample period. */
static double sample_offset(uint64_t k) { return (double)k * NN_SAMPLE_PERIOD; }

/* a in y_k = y_{k-1} + a (g u_k - y_{k-1}); a cut-off of 0 turns the filter off (a = 1). */
static double filter_coefficient(double cutoff, double period) {
    if (cutoff <= 0.0) return 1.0;
    return 1.0 - exp(-2.0 * NN_PI * cutoff * period);
}

/* Evaluate the graph with the inputs `knot` (for an interpolating FMU: its interval starts at `start`) and the graph
 * state `state`; the output filter runs over `period` seconds. With `commit` (`state` is then d->state) the state,
 * the sample counter and the envelope flags advance (a real sample; the values before it are kept to evaluate it
 * again); without it only outputs are refreshed (the preview in Initialization Mode, a communication point between
 * samples). `warn` logs inputs that leave the training envelope. */
static NNStatus evaluate(NNInstance *instance, const double *start, const double *knot, const double *state,
                         double period, int commit, int warn) {
    NNModelData *d = &instance->data;
    const unsigned long long k = (unsigned long long)d->samples_done;
    double a;
    double output[NN_OUTPUT_CAPACITY];
    int i;
    int extrapolating = 0;

    /* graph_in's entries outside these maps stay 0: calloc'd, and the directional derivatives write only these maps */
    for (i = 0; i < NN_N_INPUTS; i++) instance->graph_in[nn_input_graph_index[i]] = knot[i];
    if (NN_INTERPOLATES_INPUTS) {
        for (i = 0; i < NN_N_INPUTS; i++) instance->graph_in[nn_input_start_graph_index[i]] = start[i];
    }
    for (i = 0; i < NN_N_STATE; i++) instance->graph_in[nn_state_graph_input[i]] = state[i];
    if (nn_graph_run(instance->graph_in, instance->graph_out) != 0) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "the network failed to evaluate sample %llu", k);
        return NN_ERROR;
    }
    for (i = 0; i < NN_N_STATE; i++) {
        double value = instance->graph_out[nn_state_graph_output[i]];
        if (!isfinite(value)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "state value %d of sample %llu is %g; the sample is discarded",
                   i, k, value);
            return NN_ERROR;
        }
    }
    a = d->samples_done == 0 ? 1.0 : filter_coefficient(d->filter_cutoff, period);
    for (i = 0; i < NN_N_OUTPUTS; i++) {
        double raw = instance->graph_out[nn_output_graph_index[i]];
        double target = d->output_gain * raw;
        output[i] = (d->samples_done == 0) ? target : d->output[i] + a * (target - d->output[i]);
        if (!isfinite(output[i])) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "output '%s' of sample %llu is %g (network %g, output_gain %g); "
                   "the sample is discarded", nn_output_names[i], k, output[i], raw, d->output_gain);
            return NN_ERROR;
        }
    }

    if (commit) {
        memcpy(d->state_before, d->state, sizeof d->state);
        memcpy(d->output_before, d->output, sizeof d->output);
        memcpy(d->outside_before, d->outside, sizeof d->outside);
        memcpy(d->knot_before, d->samples_done == 0 ? knot : d->knot, sizeof d->knot);
        memcpy(d->knot, knot, sizeof d->knot);
    }
    for (i = 0; i < NN_N_INPUTS; i++) {
        int outside = knot[i] < nn_input_min[i] || knot[i] > nn_input_max[i];
        if (commit && warn && outside && !d->outside[i]) {
            nn_log(instance, NN_WARNING, NN_LOG_WARNING,
                   "sample %llu: input '%s' = %g %s lies outside the training envelope [%g, %g]; "
                   "the output is extrapolated", k, nn_input_names[i], knot[i], nn_input_units[i],
                   nn_input_min[i], nn_input_max[i]);
        }
        if (commit) d->outside[i] = outside;
        extrapolating |= outside;
    }
    d->extrapolating = extrapolating;
    d->filter_weight = a;
    memcpy(d->output, output, sizeof output);
    if (commit) {
        for (i = 0; i < NN_N_STATE; i++) d->state[i] = instance->graph_out[nn_state_graph_output[i]];
        d->samples_done++;
        d->inputs_set = 0;
        d->alpha = 0.0;
    }
    return NN_OK;
}

/* In Initialization Mode outputs are a function of the inputs set so far: evaluate sample 0 without committing. */
static NNStatus refresh_preview(NNInstance *instance) {
    NNStatus status;
    if (instance->mode != NN_INITIALIZATION || !instance->preview_stale) return NN_OK;
    status = evaluate(instance, instance->data.input, instance->data.input, instance->data.state, NN_SAMPLE_PERIOD, 0,
                      0);
    if (status == NN_OK) instance->preview_stale = 0;
    return status;
}

/* An interpolating FMU's latest sample, when it falls on the current communication point and inputs set there since
 * it was evaluated differ from those it was evaluated with, is evaluated again with them (its interval now ramps to
 * them). Without such a set the sample keeps its inputs (those set before its step, plus the slopes given). */
static NNStatus settle_latest_sample(NNInstance *instance) {
    NNModelData *d = &instance->data;
    NNStatus status;
    if (!NN_INTERPOLATES_INPUTS || instance->mode != NN_STEPPING || d->samples_done == 0 || !d->inputs_set) {
        return NN_OK;
    }
    if (fabs(sample_offset(d->samples_done - 1) - d->elapsed) > NN_SAMPLE_TOLERANCE * NN_SAMPLE_PERIOD) return NN_OK;
    if (memcmp(d->input, d->knot, sizeof d->input) == 0) {
        d->inputs_set = 0;
        return NN_OK;
    }
    memcpy(d->state, d->state_before, sizeof d->state);
    memcpy(d->output, d->output_before, sizeof d->output);
    memcpy(d->outside, d->outside_before, sizeof d->outside);
    memcpy(d->knot, d->knot_before, sizeof d->knot);
    d->samples_done--;
    status = evaluate(instance, d->knot, d->input, d->state, NN_SAMPLE_PERIOD, 1, 1);
    if (status != NN_OK) instance->mode = NN_FAILED;
    return status;
}

NNStatus nn_get_real(NNInstance *instance, unsigned vr, double *value) {
    const NNModelData *d = &instance->data;
    if (in_range(vr, NN_VR_FIRST_INPUT, NN_N_INPUTS)) {
        *value = d->input[vr - NN_VR_FIRST_INPUT];
        return NN_OK;
    }
    if (in_range(vr, NN_VR_FIRST_OUTPUT, NN_N_OUTPUTS)) {
        NNStatus status = refresh_preview(instance);
        if (status == NN_OK) status = settle_latest_sample(instance);
        *value = d->output[vr - NN_VR_FIRST_OUTPUT];
        return status;
    }
    switch (vr) {
    case NN_VR_FILTER_CUTOFF: *value = d->filter_cutoff; return NN_OK;
    case NN_VR_OUTPUT_GAIN: *value = d->output_gain; return NN_OK;
    default: break;
    }
    if (NN_HAS_TIME_VARIABLE && vr == NN_VR_TIME) {
        *value = d->time;
        return NN_OK;
    }
    return nn_refuse_type(instance, "GetReal", "Real", vr);
}

/* After one output is read without error, the preview and the latest sample are settled until an input is set:
 * the other outputs of the same call are copied (a vehicle's 66 outputs read in one call pay for one check). */
NNStatus nn_get_reals(NNInstance *instance, const unsigned vr[], size_t n, double value[]) {
    size_t i;
    int settled = 0;
    for (i = 0; i < n; i++) {
        NNStatus status;
        int output = in_range(vr[i], NN_VR_FIRST_OUTPUT, NN_N_OUTPUTS);
        if (settled && output) {
            value[i] = instance->data.output[vr[i] - NN_VR_FIRST_OUTPUT];
            continue;
        }
        status = nn_get_real(instance, vr[i], &value[i]);
        if (status != NN_OK) return status;
        settled |= output;
    }
    return NN_OK;
}

static NNStatus set_parameter(NNInstance *instance, double *target, const char *name, double value, double min) {
    if (!(instance->mode & (NN_INSTANTIATED | NN_INITIALIZATION))) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR,
               "parameter '%s' is fixed: it can only be set before initialisation ends", name);
        return NN_ERROR;
    }
    if (value < min) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "parameter '%s' = %g refused: it must be >= %g", name, value, min);
        return NN_ERROR;
    }
    *target = value;
    instance->preview_stale = 1;
    return NN_OK;
}

NNStatus nn_set_real(NNInstance *instance, unsigned vr, double value) {
    NNModelData *d = &instance->data;
    if (in_range(vr, NN_VR_FIRST_INPUT, NN_N_INPUTS)) {
        unsigned i = vr - NN_VR_FIRST_INPUT;
        if (!isfinite(value)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR,
                   "input '%s' set to %g: refused, inputs must be finite (kept %g %s)", nn_input_names[i], value,
                   d->input[i], nn_input_units[i]);
            return NN_ERROR;
        }
        d->input[i] = value;
        d->inputs_set = 1;
        instance->preview_stale = 1;
        return NN_OK;
    }
    if (!isfinite(value) && (vr == NN_VR_FILTER_CUTOFF || vr == NN_VR_OUTPUT_GAIN)) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "parameter with value reference %u set to %g: refused, must be finite",
               vr, value);
        return NN_ERROR;
    }
    if (vr == NN_VR_FILTER_CUTOFF) return set_parameter(instance, &d->filter_cutoff, "filter_cutoff", value, 0.0);
    if (vr == NN_VR_OUTPUT_GAIN) return set_parameter(instance, &d->output_gain, "output_gain", value, -HUGE_VAL);
    if (in_range(vr, NN_VR_FIRST_OUTPUT, NN_N_OUTPUTS)) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "'%s' (value reference %u) is an output and cannot be set",
               nn_output_names[vr - NN_VR_FIRST_OUTPUT], vr);
        return NN_ERROR;
    }
    return nn_refuse_type(instance, "SetReal", "settable Real", vr);
}

NNStatus nn_set_reals(NNInstance *instance, const unsigned vr[], size_t n, const double value[]) {
    size_t i;
    /* A master's call every step: finite inputs, stored as nn_set_real would store them, without a call per value;
     * from the first other value on (a parameter, an output, a non-finite value) value by value. */
    for (i = 0; i < n && in_range(vr[i], NN_VR_FIRST_INPUT, NN_N_INPUTS) && isfinite(value[i]); i++) {
        instance->data.input[vr[i] - NN_VR_FIRST_INPUT] = value[i];
    }
    if (i > 0) {
        instance->data.inputs_set = 1;
        instance->preview_stale = 1;
    }
    for (; i < n; i++) {
        NNStatus status = nn_set_real(instance, vr[i], value[i]);
        if (status != NN_OK) return status;
    }
    return NN_OK;
}

NNStatus nn_set_input_slopes(NNInstance *instance, const unsigned vr[], size_t n, const int order[],
                             const double value[]) {
    NNModelData *d = &instance->data;
    size_t i;
    if (!NN_INTERPOLATES_INPUTS) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SetRealInputDerivatives: %s samples its inputs and cannot "
               "interpolate them (canInterpolateInputs is false)", NN_MODEL_IDENTIFIER);
        return NN_ERROR;
    }
    for (i = 0; i < n; i++) {
        if (!in_range(vr[i], NN_VR_FIRST_INPUT, NN_N_INPUTS)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SetRealInputDerivatives: value reference %u is not an input",
                   vr[i]);
            return NN_ERROR;
        }
        if (order[i] != 1) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SetRealInputDerivatives: input '%s': derivative order %d "
                   "refused (inputs are interpolated linearly: order 1 only)",
                   nn_input_names[vr[i] - NN_VR_FIRST_INPUT], order[i]);
            return NN_ERROR;
        }
        if (!isfinite(value[i])) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SetRealInputDerivatives: input '%s': derivative %g refused, "
                   "it must be finite", nn_input_names[vr[i] - NN_VR_FIRST_INPUT], value[i]);
            return NN_ERROR;
        }
    }
    for (i = 0; i < n; i++) d->input_slope[vr[i] - NN_VR_FIRST_INPUT] = value[i];
    return NN_OK;
}

NNStatus nn_get_boolean(NNInstance *instance, unsigned vr, int *value) {
    if (vr == NN_VR_EXTRAPOLATING) {
        NNStatus status = refresh_preview(instance);
        if (status == NN_OK) status = settle_latest_sample(instance);
        *value = instance->data.extrapolating;
        return status;
    }
    return nn_refuse_type(instance, "GetBoolean", "Boolean", vr);
}

NNStatus nn_refuse_type(const NNInstance *instance, const char *function, const char *type, unsigned vr) {
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: value reference %u is not a %s variable of %s", function, vr, type,
           NN_MODEL_IDENTIFIER);
    return NN_ERROR;
}

/* Sets the instance's start time and current time to `start_time`, or logs (naming `function`) why not. */
static NNStatus set_start_time(NNInstance *instance, const char *function, double start_time) {
    if (!isfinite(start_time)) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: start time %g is not finite", function, start_time);
        return NN_ERROR;
    }
    instance->data.start_time = start_time;
    instance->data.time = start_time;
    return NN_OK;
}

NNStatus nn_setup_experiment(NNInstance *instance, double start_time) {
    return set_start_time(instance, "SetupExperiment", start_time);
}

NNStatus nn_enter_initialization(NNInstance *instance, double start_time) {
    if (set_start_time(instance, "EnterInitializationMode", start_time) != NN_OK) return NN_ERROR;
    instance->data.elapsed = 0.0;
    instance->data.elapsed_carry = 0.0;
    instance->mode = NN_INITIALIZATION;
    instance->preview_stale = 1;
    return NN_OK;
}

NNStatus nn_exit_initialization(NNInstance *instance) {
    NNStatus status = evaluate(instance, instance->data.input, instance->data.input, instance->data.state,
                               NN_SAMPLE_PERIOD, 1, 1);
    if (status != NN_OK) {
        instance->mode = NN_FAILED;
        return status;
    }
    instance->mode = NN_STEPPING;
    nn_log(instance, NN_OK, NN_LOG_EVENTS, "initialised at t = %.17g s; sample 0 evaluated", instance->data.time);
    return NN_OK;
}

/* sum + step with Kahan's compensation (*carry holds what earlier sums lost), so that the elapsed time after n steps
 * of h is n*h to the last bit or so: where a step ends between samples decides its outputs. */
static double compensated_sum(double sum, double step, double *carry) {
    const double y = step - *carry;
    const double total = sum + y;
    *carry = (total - sum) - y;
    return total;
}

/* Number of samples due in a step that ends `elapsed_end` seconds after t_start. */
static uint64_t samples_due(const NNModelData *d, double elapsed_end) {
    double last = floor(elapsed_end / NN_SAMPLE_PERIOD + NN_SAMPLE_TOLERANCE);
    if (!(last + 1.0 > (double)d->samples_done)) return 0;
    if (last + 1.0 - (double)d->samples_done > (double)NN_MAX_SAMPLES_PER_STEP) return NN_MAX_SAMPLES_PER_STEP + 1;
    return (uint64_t)(last + 1.0) - d->samples_done;
}

/* Evaluate the `count` samples a step from `step_start` (elapsed time) reaches, with the inputs set before it (plus
 * their slopes over the time from the step's start, for an interpolating FMU); each sample's output filter runs
 * from the time the outputs were last evaluated. */
static NNStatus step_samples(NNInstance *instance, uint64_t count, double step_start) {
    NNModelData *d = &instance->data;
    double knot[NN_INPUT_CAPACITY];
    NNStatus status = NN_OK;
    uint64_t j;
    int i;
    for (j = 0; j < count && status == NN_OK; j++) {
        const double at = sample_offset(d->samples_done);
        const double ahead = at - step_start;
        for (i = 0; i < NN_N_INPUTS; i++) knot[i] = d->input[i] + (NN_INTERPOLATES_INPUTS ? ahead * d->input_slope[i] : 0.0);
        status = evaluate(instance, d->knot, knot, d->state, at - d->evaluated_at, 1, 1);
        d->evaluated_at = at;
    }
    return status;
}

/* The graph state at the latest evaluation: before the first sample the initial state, at a sample the state it
 * was evaluated from, between samples (1 - alpha) s_k + alpha s_{k+1}. */
static void current_graph_state(const NNModelData *d, double *state) {
    int i;
    for (i = 0; i < NN_N_STATE; i++) {
        state[i] = d->samples_done == 0 ? d->state[i] : (1.0 - d->alpha) * d->state_before[i] + d->alpha * d->state[i];
    }
}

/* A step of a sampled FMU that ends between samples: outputs from the inputs set before it and the interpolated
 * graph state at `elapsed_end`, the output filter run up to it; the graph state stays at the latest sample. */
static NNStatus evaluate_between(NNInstance *instance, double elapsed_end) {
    NNModelData *d = &instance->data;
    double state[NN_STATE_CAPACITY];
    const double alpha = (elapsed_end - sample_offset(d->samples_done - 1)) / NN_SAMPLE_PERIOD;
    NNStatus status;
    if (NN_INTERPOLATES_INPUTS || d->samples_done == 0 || !(alpha > NN_SAMPLE_TOLERANCE)) return NN_OK;
    d->alpha = fmin(alpha, 1.0);
    current_graph_state(d, state);
    status = evaluate(instance, d->knot, d->input, state, elapsed_end - d->evaluated_at, 0, 0);
    d->evaluated_at = elapsed_end;
    return status;
}

NNStatus nn_do_step(NNInstance *instance, double current_time, double step_size) {
    NNModelData *d = &instance->data;
    double elapsed_end;
    double carry = d->elapsed_carry;
    NNStatus status = NN_OK;
    if (!isfinite(current_time) || !isfinite(step_size) || step_size < 0.0) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DoStep(t = %g s, h = %g s) refused: t must be finite and h >= 0",
               current_time, step_size);
        return NN_ERROR;
    }
    if (fabs(current_time - d->time) > NN_TIME_TOLERANCE * fmax(1.0, fabs(current_time))) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DoStep: communication point %.17g s does not continue from the "
               "FMU's time %.17g s", current_time, d->time);
        return NN_ERROR;
    }
    elapsed_end = compensated_sum(d->elapsed, step_size, &carry);
    if (NN_HAS_SAMPLE_PERIOD) {
        uint64_t due = samples_due(d, elapsed_end);
        if (due > NN_MAX_SAMPLES_PER_STEP) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DoStep(t = %g s, h = %g s) refused: it spans %.6g samples of "
                   "%g s, more than the %llu one step may evaluate; take shorter steps", current_time, step_size,
                   step_size / NN_SAMPLE_PERIOD, NN_SAMPLE_PERIOD, (unsigned long long)NN_MAX_SAMPLES_PER_STEP);
            return NN_ERROR;
        }
        status = settle_latest_sample(instance);
        if (status == NN_OK) status = step_samples(instance, due, d->elapsed);
        if (status == NN_OK) status = evaluate_between(instance, elapsed_end);
    } else {
        status = evaluate(instance, d->knot, d->input, d->state, step_size, 1, 1);
    }
    if (status != NN_OK) {
        instance->mode = NN_FAILED;
        return status;
    }
    memset(d->input_slope, 0, sizeof d->input_slope);
    d->elapsed = elapsed_end;
    d->elapsed_carry = carry;
    d->time = current_time + step_size;
    return NN_OK;
}

NNStatus nn_state_save(NNInstance *instance, void **state) {
    if (!*state) *state = malloc(sizeof(NNModelData)); /* a state from an earlier call is overwritten in place */
    if (!*state) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "out of memory while saving the FMU state");
        return NN_ERROR;
    }
    instance->data.mode = (int)instance->mode;
    memcpy(*state, &instance->data, sizeof(NNModelData));
    return NN_OK;
}

void nn_state_free(void **state) {
    if (!state) return;
    free(*state);
    *state = NULL;
}

NNStatus nn_state_restore(NNInstance *instance, const NNModelData *state) {
    memcpy(&instance->data, state, sizeof *state);
    instance->mode = (NNMode)state->mode; /* also the way back from an error: FMI allows rolling back to a state */
    instance->preview_stale = 1;
    nn_log(instance, NN_OK, NN_LOG_EVENTS, "FMU state restored to t = %.17g s (%llu samples done)",
           instance->data.time, (unsigned long long)instance->data.samples_done);
    return NN_OK;
}

/* 1 if every value of `n` doubles is finite. */
static int all_finite(const double *values, size_t n) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (!isfinite(values[i])) return 0;
    }
    return 1;
}

/* 1 if a deserialised state could have been saved by this FMU: a known mode, finite values, a sample counter that
 * matches its time; else logs which field is wrong and returns 0. */
static int plausible_state(const NNInstance *instance, const NNModelData *s) {
    const char *wrong = NULL;
    const int modes = NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED;
    int i;
    if (!(s->mode & modes) || (s->mode & (s->mode - 1))) wrong = "mode";
    else if (!isfinite(s->time) || !isfinite(s->start_time) || !isfinite(s->elapsed) || s->elapsed < 0.0 ||
             fabs(s->time - (s->start_time + s->elapsed)) > NN_TIME_CONSISTENCY * fmax(1.0, fabs(s->time))) {
        wrong = "time";
    }
    else if (!isfinite(s->evaluated_at) || s->evaluated_at < 0.0 || s->evaluated_at > s->elapsed * (1.0 + 1e-12) ||
             !isfinite(s->alpha) || s->alpha < 0.0 || s->alpha > 1.0 || !isfinite(s->elapsed_carry) ||
             !(s->filter_weight >= 0.0 && s->filter_weight <= 1.0) ||
             fabs(s->elapsed_carry) > 1e-9 * fmax(1.0, s->elapsed)) {
        wrong = "time";
    }
    else if (!isfinite(s->filter_cutoff) || s->filter_cutoff < 0.0) wrong = "filter_cutoff";
    else if (!isfinite(s->output_gain)) wrong = "output_gain";
    else if (!all_finite(s->input, NN_INPUT_CAPACITY) || !all_finite(s->input_slope, NN_INPUT_CAPACITY) ||
             !all_finite(s->knot, NN_INPUT_CAPACITY) || !all_finite(s->knot_before, NN_INPUT_CAPACITY)) wrong = "inputs";
    else if (!all_finite(s->output, NN_OUTPUT_CAPACITY) || !all_finite(s->output_before, NN_OUTPUT_CAPACITY)) {
        wrong = "outputs";
    } else if (!all_finite(s->state, NN_STATE_CAPACITY) || !all_finite(s->state_before, NN_STATE_CAPACITY)) {
        wrong = "network state";
    } else if ((s->extrapolating & ~1) != 0 || (s->inputs_set & ~1) != 0) {
        wrong = "flags";
    } else if (s->mode == NN_INSTANTIATED || s->mode == NN_INITIALIZATION) {
        if (s->samples_done != 0) wrong = "sample counter";
    } else if (NN_HAS_SAMPLE_PERIOD && s->mode == NN_STEPPING) {
        /* Not checked once terminated: the instance never steps again, and termination after a failed
         * initialisation or step leaves the counter where the failure did. */
        double expected = floor(s->elapsed / NN_SAMPLE_PERIOD + NN_SAMPLE_TOLERANCE) + 1.0;
        if ((double)s->samples_done != expected) wrong = "sample counter";
    }
    for (i = 0; !wrong && i < NN_INPUT_CAPACITY; i++) {
        if ((s->outside[i] & ~1) != 0 || (s->outside_before[i] & ~1) != 0) wrong = "envelope flags";
    }
    if (!wrong) return 1;
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DeserializeFMUstate: the state's %s is not one this FMU can have "
           "(time %g s, %llu samples done); refused", wrong, s->time, (unsigned long long)s->samples_done);
    return 0;
}

size_t nn_serialized_size(void) { return sizeof(NNStateHeader) + sizeof(NNModelData); }

NNStatus nn_serialize(const NNInstance *instance, const NNModelData *state, unsigned char *buffer, size_t size) {
    NNStateHeader header;
    if (size != nn_serialized_size()) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "SerializeFMUstate: buffer has %lu bytes, expected %lu",
               (unsigned long)size, (unsigned long)nn_serialized_size());
        return NN_ERROR;
    }
    memset(&header, 0, sizeof header);
    memcpy(header.magic, NN_STATE_MAGIC, NN_MAGIC_SIZE);
    header.size = (uint64_t)nn_serialized_size();
    memcpy(header.token, NN_INSTANTIATION_TOKEN, sizeof(NN_INSTANTIATION_TOKEN));
    memcpy(buffer, &header, sizeof header);
    memcpy(buffer + sizeof header, state, sizeof *state);
    return NN_OK;
}

NNStatus nn_deserialize(const NNInstance *instance, const unsigned char *buffer, size_t size, void **state) {
    NNStateHeader header;
    NNModelData *copy;
    if (size != nn_serialized_size()) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DeserializeFMUstate: %lu bytes given, an FMU state of %s has %lu",
               (unsigned long)size, NN_MODEL_IDENTIFIER, (unsigned long)nn_serialized_size());
        return NN_ERROR;
    }
    memcpy(&header, buffer, sizeof header);
    if (memcmp(header.magic, NN_STATE_MAGIC, NN_MAGIC_SIZE) != 0 || header.size != (uint64_t)size) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DeserializeFMUstate: the bytes are not a serialised nnfmu FMU state");
        return NN_ERROR;
    }
    if (memcmp(header.token, NN_INSTANTIATION_TOKEN, sizeof(NN_INSTANTIATION_TOKEN)) != 0) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "DeserializeFMUstate: the state was saved by another FMU "
               "(token '%.*s', expected '%s')", NN_TOKEN_FIELD - 1, header.token, NN_INSTANTIATION_TOKEN);
        return NN_ERROR;
    }
    copy = (NNModelData *)malloc(sizeof(NNModelData));
    if (!copy) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "out of memory while deserialising the FMU state");
        return NN_ERROR;
    }
    memcpy(copy, buffer + sizeof header, sizeof *copy);
    if (!plausible_state(instance, copy)) {
        free(copy);
        return NN_ERROR;
    }
    free(*state);
    *state = copy;
    return NN_OK;
}

/* ---- Directional derivatives: fmi2GetDirectionalDerivative, fmi3GetDirectionalDerivative ----
 *
 * d(outputs)/d(inputs) times a seed, exact (forward mode through the generated graph, nn_graph_jvp), at the current
 * point: the inputs set now (`input`), the graph state of current_graph_state and, for an interpolating FMU, the
 * inputs its latest sample's interval starts from (held, like the state). The output gain and filter scale it as they
 * scale the network's output (output_weight). docs/fmu.md, "Directional derivatives". */

/* d(output)/d(network output) of the latest evaluation: output_gain times the filter's weight of the new value
 * (1 for sample 0, whose output is not filtered, and with the filter off), as the evaluation stored it. */
static double output_weight(const NNInstance *instance) {
    const NNModelData *d = &instance->data;
    return d->output_gain * (d->samples_done == 0 ? 1.0 : d->filter_weight);
}

/* 1 if every unknown is a Real output and every known an input, else logs the first that is not and returns 0. */
static int derivative_references(const NNInstance *instance, const char *function, const unsigned unknowns[],
                                 size_t n_unknowns, const unsigned knowns[], size_t n_knowns) {
    size_t i;
    for (i = 0; i < n_unknowns; i++) {
        if (!in_range(unknowns[i], NN_VR_FIRST_OUTPUT, NN_N_OUTPUTS)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: unknown with value reference %u is not a real output of %s "
                   "(unknowns must be outputs)", function, unknowns[i], NN_MODEL_IDENTIFIER);
            return 0;
        }
    }
    for (i = 0; i < n_knowns; i++) {
        if (!in_range(knowns[i], NN_VR_FIRST_INPUT, NN_N_INPUTS)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: known with value reference %u is not an input of %s "
                   "(knowns must be inputs)", function, knowns[i], NN_MODEL_IDENTIFIER);
            return 0;
        }
    }
    return 1;
}

/* out_dot = J in_dot at the point in instance->graph_in (outputs into graph_out), or logged why not. */
static NNStatus graph_derivative(NNInstance *instance, const char *function, const double *in_dot, double *out_dot) {
#if NN_HAS_JVP
    if (nn_graph_jvp(instance->graph_in, in_dot, instance->graph_out, out_dot) == 0) return NN_OK;
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: the network's derivative failed to evaluate", function);
#else
    (void)in_dot;
    (void)out_dot;
    nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: %s provides no directional derivatives (an operator of its graph "
           "has no tangent rule)", function, NN_MODEL_IDENTIFIER);
#endif
    return NN_ERROR;
}

NNStatus nn_directional_derivative(NNInstance *instance, const char *function, const unsigned unknowns[],
                                   size_t n_unknowns, const unsigned knowns[], size_t n_knowns, const double seed[],
                                   double sensitivity[]) {
    const NNModelData *d = &instance->data;
    const int starts_move = NN_INTERPOLATES_INPUTS && d->samples_done == 0; /* the preview's interval is the point */
    double in_dot[NN_N_IN];
    double out_dot[NN_N_OUT];
    double state[NN_STATE_CAPACITY];
    double weight;
    size_t i;
    int j;
    if (!derivative_references(instance, function, unknowns, n_unknowns, knowns, n_knowns)) return NN_ERROR;
    weight = output_weight(instance);
    memset(instance->graph_in, 0, sizeof instance->graph_in);
    memset(in_dot, 0, sizeof in_dot);
    current_graph_state(d, state);
    for (j = 0; j < NN_N_INPUTS; j++) {
        instance->graph_in[nn_input_graph_index[j]] = d->input[j];
        if (NN_INTERPOLATES_INPUTS) {
            instance->graph_in[nn_input_start_graph_index[j]] = starts_move ? d->input[j] : d->knot_before[j];
        }
    }
    for (j = 0; j < NN_N_STATE; j++) instance->graph_in[nn_state_graph_input[j]] = state[j];
    for (i = 0; i < n_knowns; i++) {
        const unsigned port = knowns[i] - NN_VR_FIRST_INPUT;
        in_dot[nn_input_graph_index[port]] += seed[i];
        if (starts_move) in_dot[nn_input_start_graph_index[port]] += seed[i];
    }
    if (graph_derivative(instance, function, in_dot, out_dot) != NN_OK) return NN_ERROR;
    for (i = 0; i < n_unknowns; i++) {
        const unsigned port = unknowns[i] - NN_VR_FIRST_OUTPUT;
        const double value = weight * out_dot[nn_output_graph_index[port]];
        if (!isfinite(value)) {
            nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: the derivative of output '%s' is %g at the current inputs "
                   "and state", function, nn_output_names[port], value);
            return NN_ERROR;
        }
        sensitivity[i] = value;
    }
    return NN_OK;
}
