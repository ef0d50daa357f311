/* fuzz_driver.c: drives an FMI 2.0 or 3.0 co-simulation FMU with random call sequences for test_fuzz.py (run under
 * ASan+UBSan, so any invalid access or undefined behaviour aborts the run).
 *
 * Usage: fuzz_driver FMI BINARY GUID N_INPUTS N_OUTPUTS N_REALS SEED SECONDS MAX_SEQUENCES
 *   FMI: 2 or 3. The sequences are written against the FMI 2 functions; for FMI 3 small adapters call the FMI 3
 *   counterparts (SetupExperiment keeps the start time for EnterInitializationMode, input derivatives go to the
 *   refused GetOutputDerivatives, the Boolean status to the refused EnterEventMode).
 *   N_REALS: one past the highest Real value reference (inputs come first, then outputs, as nnfmu numbers them).
 * Sequence s (s = 0, 1, ...) draws its calls from the seed SEED + s: instances created and freed, initialisation,
 * reals set and read with valid and invalid value references and values (NaN, inf, huge, denormal), steps with
 * valid, zero, negative, huge and non-finite sizes at right and wrong communication points, FMU states saved,
 * restored, serialised and deserialised from intact, truncated and corrupted bytes, reset and terminate in any mode,
 * directional derivatives of any value references with ordinary and hostile seeds.
 * Half the calls are well-formed ones for the mode the driver believes an instance is in (set up, initialise, set
 * inputs and step), so that sequences reach far into stepping between the hostile ones.
 * It stops after SECONDS or MAX_SEQUENCES sequences. Checked invariants: every status is a valid fmi2Status, the
 * outputs read after an OK doStep (and any OK read of outputs or derivatives) are finite, a state serialised and
 * deserialised intact is accepted, an OK fmi3DoStep reports no event, no termination, no early return and t + h as
 * its last successful time. Exits 0 when no invariant broke, printing how many sequences and calls ran.
 */
#define _POSIX_C_SOURCE 200112L /* clock_gettime */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <dlfcn.h>
#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define SLOTS 3          /* instances alive at once */
#define CALLS 300        /* calls per sequence */
#define MAX_VR 16        /* value references per Get/Set call */

static unsigned long long rng_state;
static int failures = 0;
static long long calls = 0, ok_calls = 0, logged = 0;
/* how deep the sequences reach */
static long long ok_steps = 0, ok_restores = 0, ok_slopes = 0, ok_derivatives = 0;
static unsigned long long current_seed = 0;
static char last_message[2048]; /* the FMU's latest log message, shown with a failure */

/* xorshift64*: a small, seedable generator whose sequences are the same on every platform. */
static unsigned long long next_random(void) {
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return rng_state * 2685821657736338717ULL;
}

static unsigned below(unsigned n) { return (unsigned)(next_random() % n); }

static double uniform(void) { return (double)(next_random() >> 11) / 9007199254740992.0; }

/* A value that is mostly ordinary and sometimes hostile: NaN, infinities, huge, tiny and denormal. */
static double any_value(void) {
    switch (below(12)) {
    case 0: return NAN;
    case 1: return below(2) ? HUGE_VAL : -HUGE_VAL;
    case 2: return below(2) ? 1e308 : -1e300;
    case 3: return 4.9e-324 * (double)(1 + below(1000));
    case 4: return 0.0;
    case 5: return -0.0;
    case 6: return (uniform() - 0.5) * 1e6;
    default: return (uniform() - 0.5) * 4.0;
    }
}

/* The logger formats every message, as a master would, without printing it (the runs log millions of lines). */
static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    va_list args;
    (void)env;
    (void)status;
    if (!name || !category || !message) {
        fprintf(stderr, "seed %llu: logger called with a NULL string\n", current_seed);
        failures++;
        return;
    }
    va_start(args, message);
    vsnprintf(last_message, sizeof last_message, message, args);
    va_end(args);
    logged++;
}

typedef struct {
    fmi2Component c;
    double t;              /* the time this driver believes the instance is at */
    int stage;             /* the mode it believes the instance is in: 0 instantiated, 1 initialising, 2 stepping,
                            * 3 anything else (ended or failed) */
    fmi2FMUstate states[2];
    double state_t[2];
    int state_stage[2];
} Slot;

#define CHECK(status_expr) check_status((int)(status_expr), __LINE__)

/* Counts the call and fails on a status outside fmi2Status; returns the status. */
static int check_status(int status, int line) {
    calls++;
    if (status < fmi2OK || status > fmi2Pending) {
        fprintf(stderr, "seed %llu, line %d: status %d is not an fmi2Status\n", current_seed, line, status);
        failures++;
    }
    if (status == fmi2OK) ok_calls++;
    return status;
}

static double now_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* The FMU's functions, looked up once. */
static struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetDebugLoggingTYPE *set_debug_logging;
    fmi2SetupExperimentTYPE *setup;
    fmi2EnterInitializationModeTYPE *enter;
    fmi2ExitInitializationModeTYPE *exit_init;
    fmi2TerminateTYPE *terminate;
    fmi2ResetTYPE *reset;
    fmi2GetRealTYPE *get_real;
    fmi2SetRealTYPE *set_real;
    fmi2GetBooleanTYPE *get_boolean;
    fmi2GetIntegerTYPE *get_integer;
    fmi2SetRealInputDerivativesTYPE *set_slopes;
    fmi2DoStepTYPE *do_step;
    fmi2GetRealStatusTYPE *get_real_status;
    fmi2GetBooleanStatusTYPE *get_boolean_status;
    fmi2GetFMUstateTYPE *get_state;
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
    fmi2SerializedFMUstateSizeTYPE *state_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    fmi2GetDirectionalDerivativeTYPE *derivative;
} f;


/* The FMI 3 functions the adapters below call. */
static struct {
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3InstantiateModelExchangeTYPE *instantiate_me;
    fmi3FreeInstanceTYPE *free_instance;
    fmi3SetDebugLoggingTYPE *set_debug_logging;
    fmi3EnterInitializationModeTYPE *enter;
    fmi3ExitInitializationModeTYPE *exit_init;
    fmi3EnterEventModeTYPE *enter_event_mode;
    fmi3TerminateTYPE *terminate;
    fmi3ResetTYPE *reset;
    fmi3GetFloat64TYPE *get_float64;
    fmi3SetFloat64TYPE *set_float64;
    fmi3GetBooleanTYPE *get_boolean;
    fmi3GetInt32TYPE *get_int32;
    fmi3GetOutputDerivativesTYPE *get_output_derivatives;
    fmi3DoStepTYPE *do_step;
    fmi3GetFMUStateTYPE *get_state;
    fmi3SetFMUStateTYPE *set_state;
    fmi3FreeFMUStateTYPE *free_state;
    fmi3SerializedFMUStateSizeTYPE *state_size;
    fmi3SerializeFMUStateTYPE *serialize;
    fmi3DeserializeFMUStateTYPE *deserialize;
    fmi3GetDirectionalDerivativeTYPE *derivative;
} g;

/* FMI 3 takes the start time in EnterInitializationMode: SetupExperiment's is kept per instance until then. */
static struct {
    fmi2Component c;
    double start;
} starts[SLOTS];

static double *start_of(fmi2Component c) {
    int i;
    for (i = 0; i < SLOTS; i++) {
        if (starts[i].c == c) return &starts[i].start;
    }
    for (i = 0; i < SLOTS; i++) {
        if (!starts[i].c) {
            starts[i].c = c;
            starts[i].start = 0.0;
            return &starts[i].start;
        }
    }
    return NULL;
}

static void log3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    logger(env, "fmi3", (fmi2Status)status, category, "%s", message);
}

static fmi2Component instantiate3(fmi2String name, fmi2Type type, fmi2String token, fmi2String resources,
                                  const fmi2CallbackFunctions *functions, fmi2Boolean visible, fmi2Boolean logging) {
    (void)functions;
    if (type != fmi2CoSimulation) {
        return g.instantiate_me(name, token, resources, visible != 0, logging != 0, NULL, log3);
    }
    return g.instantiate(name, token, resources, visible != 0, logging != 0, fmi3False, fmi3False, NULL, 0, NULL, log3,
                         NULL);
}

static void free_instance3(fmi2Component c) {
    int i;
    for (i = 0; i < SLOTS; i++) {
        if (starts[i].c == c) starts[i].c = NULL;
    }
    g.free_instance(c);
}

static fmi2Status set_debug_logging3(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    return (fmi2Status)g.set_debug_logging(c, on != 0, n, categories);
}

static fmi2Status setup3(fmi2Component c, fmi2Boolean tolerance_defined, fmi2Real tolerance, fmi2Real start_time,
                         fmi2Boolean stop_defined, fmi2Real stop_time) {
    double *start = start_of(c);
    (void)tolerance_defined;
    (void)tolerance;
    (void)stop_defined;
    (void)stop_time;
    if (start) *start = start_time;
    return fmi2OK;
}

static fmi2Status enter3(fmi2Component c) {
    double *start = start_of(c);
    return (fmi2Status)g.enter(c, fmi3False, 0.0, start ? *start : 0.0, fmi3False, 0.0);
}

static fmi2Status exit_init3(fmi2Component c) { return (fmi2Status)g.exit_init(c); }

static fmi2Status terminate3(fmi2Component c) { return (fmi2Status)g.terminate(c); }

static fmi2Status reset3(fmi2Component c) {
    double *start = start_of(c);
    if (start) *start = 0.0;
    return (fmi2Status)g.reset(c);
}

static fmi2Status get_real3(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real values[]) {
    return (fmi2Status)g.get_float64(c, vr, n, values, n);
}

static fmi2Status set_real3(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real values[]) {
    return (fmi2Status)g.set_float64(c, vr, n, values, n);
}

static fmi2Status get_boolean3(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean values[]) {
    fmi3Boolean flags[MAX_VR];
    fmi2Status status;
    size_t i;
    if (n > MAX_VR) return fmi2Error;
    status = (fmi2Status)g.get_boolean(c, vr, n, values ? flags : NULL, n);
    for (i = 0; values && status == fmi2OK && i < n; i++) values[i] = flags[i] ? fmi2True : fmi2False;
    return status;
}

static fmi2Status get_integer3(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer values[]) {
    fmi3Int32 got[MAX_VR];
    (void)values;
    return n > MAX_VR ? fmi2Error : (fmi2Status)g.get_int32(c, vr, n, got, n);
}

static fmi2Status set_slopes3(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer order[],
                              const fmi2Real values[]) {
    fmi3Int32 orders[MAX_VR];
    fmi3Float64 got[MAX_VR];
    size_t i;
    (void)values;
    if (n > MAX_VR) return fmi2Error;
    for (i = 0; i < n; i++) orders[i] = order[i];
    return (fmi2Status)g.get_output_derivatives(c, vr, n, orders, got, n);
}

static fmi2Status derivative3(fmi2Component c, const fmi2ValueReference unknowns[], size_t n_unknowns,
                               const fmi2ValueReference knowns[], size_t n_knowns, const fmi2Real seed[],
                               fmi2Real sensitivity[]) {
    return (fmi2Status)g.derivative(c, unknowns, n_unknowns, knowns, n_knowns, seed, n_knowns, sensitivity,
                                    n_unknowns);
}

static fmi2Status do_step3(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_set_prior) {
    fmi3Boolean event = fmi3True, terminate = fmi3True, early = fmi3True;
    fmi3Float64 last = NAN;
    fmi3Status status = g.do_step(c, t, h, no_set_prior != 0, &event, &terminate, &early, &last);
    if (status == fmi3OK && (event || terminate || early || !(fabs(last - (t + h)) <= 1e-9 * fmax(1.0, fabs(t))))) {
        fprintf(stderr, "seed %llu: fmi3DoStep OK but flags %d %d %d, last successful time %g for t + h = %g\n",
                current_seed, event, terminate, early, last, t + h);
        failures++;
    }
    return (fmi2Status)status;
}

static fmi2Status get_real_status3(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    double *start = start_of(c); /* only asked right after EnterInitializationMode, when the time is the start */
    (void)kind;
    *value = start ? *start : 0.0;
    return fmi2OK;
}

static fmi2Status get_boolean_status3(fmi2Component c, const fmi2StatusKind kind, fmi2Boolean *value) {
    (void)kind;
    (void)value;
    return (fmi2Status)g.enter_event_mode(c);
}

static fmi2Status get_state3(fmi2Component c, fmi2FMUstate *state) { return (fmi2Status)g.get_state(c, state); }

static fmi2Status set_state3(fmi2Component c, fmi2FMUstate state) { return (fmi2Status)g.set_state(c, state); }

static fmi2Status free_state3(fmi2Component c, fmi2FMUstate *state) { return (fmi2Status)g.free_state(c, state); }

static fmi2Status state_size3(fmi2Component c, fmi2FMUstate state, size_t *size) {
    return (fmi2Status)g.state_size(c, state, size);
}

static fmi2Status serialize3(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    return (fmi2Status)g.serialize(c, state, (fmi3Byte *)bytes, size);
}

static fmi2Status deserialize3(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    return (fmi2Status)g.deserialize(c, (const fmi3Byte *)bytes, size, state);
}

static int n_in, n_out, n_reals;
static const char *guid;
static fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

/* A value reference: mostly a valid one of the given range, sometimes any Real one or one that does not exist. */
static fmi2ValueReference pick_vr(int first, int count) {
    switch (below(10)) {
    case 0: return (fmi2ValueReference)(n_reals + below(4));
    case 1: return below(2) ? 0xFFFFFFFFu : 0x80000000u;
    case 2: return (fmi2ValueReference)below((unsigned)n_reals + 1);
    default: return (fmi2ValueReference)(first + (count > 0 ? (int)below((unsigned)count) : 0));
    }
}

/* A step size: mostly a small valid one, sometimes zero, negative, huge, denormal or not finite. */
static double pick_step(void) {
    switch (below(16)) {
    case 0: return 0.0;
    case 1: return -1e-3 * uniform();
    case 2: return NAN;
    case 3: return HUGE_VAL;
    case 4: return 1e300;
    case 5: return 10.0 * uniform();
    case 6: return 4.9e-324;
    case 7: return 1e-9 * uniform();
    default: return 5e-3 * uniform();
    }
}

/* A communication point: mostly the instance's time, sometimes a little or far off it or not finite. */
static double pick_point(double t) {
    switch (below(12)) {
    case 0: return NAN;
    case 1: return t + 1e-3;
    case 2: return t * (1.0 + 1e-14);
    case 3: return -t - 1.0;
    case 4: return any_value();
    default: return t;
    }
}

/* Reads every output; after an OK read they must be finite. Returns the status. */
static int read_outputs(Slot *s, int line) {
    fmi2ValueReference vr[MAX_VR];
    fmi2Real out[MAX_VR];
    int i, status;
    for (i = 0; i < n_out; i++) vr[i] = (fmi2ValueReference)(n_in + i);
    status = check_status(f.get_real(s->c, vr, (size_t)n_out, out), line);
    for (i = 0; status == fmi2OK && i < n_out; i++) {
        if (!isfinite(out[i])) {
            fprintf(stderr, "seed %llu, line %d: output %d is %g after an OK call\n", current_seed, line, i, out[i]);
            failures++;
        }
    }
    return status;
}

static void free_slot(Slot *s) {
    int k;
    for (k = 0; k < 2; k++) {
        if (s->states[k]) CHECK(f.free_state(s->c, &s->states[k]));
        s->states[k] = NULL;
    }
    f.free_instance(s->c);
    calls++;
    memset(s, 0, sizeof *s);
}

static void instantiate(Slot *s) {
    static const char *names[] = {"fuzz", "", "a%s%n%d", "a long name ..........................................."};
    const char *token = guid;
    fmi2Type type = fmi2CoSimulation;
    switch (below(8)) {
    case 0: token = "{not-the-guid}"; break;
    case 1: token = ""; break;
    case 2: type = fmi2ModelExchange; break;
    default: break;
    }
    s->c = f.instantiate(names[below(4)], type, token, below(2) ? "file:///nowhere" : NULL, &callbacks,
                         fmi2False, (fmi2Boolean)below(2));
    calls++;
    s->t = 0.0;
    if (s->c && (token != guid || type != fmi2CoSimulation)) {
        fprintf(stderr, "seed %llu: an instance was made with a wrong token or type\n", current_seed);
        failures++;
    }
}

/* Saves, serialises, round-trips and corrupts a state of slot `s`. */
static void exercise_states(Slot *s) {
    int k = (int)below(2);
    size_t size = 0;
    fmi2Byte *bytes;
    fmi2FMUstate copy = NULL;
    if (CHECK(f.get_state(s->c, &s->states[k])) == fmi2OK) {
        s->state_t[k] = s->t;
        s->state_stage[k] = s->stage;
    }
    if (!s->states[k]) return;
    if (CHECK(f.state_size(s->c, s->states[k], &size)) != fmi2OK || size == 0 || size > (1u << 20)) return;
    bytes = (fmi2Byte *)malloc(size);
    if (!bytes) return;
    if (CHECK(f.serialize(s->c, s->states[k], bytes, size)) == fmi2OK) {
        if (CHECK(f.deserialize(s->c, bytes, size, &copy)) != fmi2OK) {
            fprintf(stderr, "seed %llu: an intact serialised state was refused: %s\n", current_seed, last_message);
            failures++;
        }
        switch (below(4)) {
        case 0: CHECK(f.deserialize(s->c, bytes, size - 1 - below((unsigned)size), &copy)); break;
        case 1: {
            int flips = 1 + (int)below(8), i;
            for (i = 0; i < flips; i++) bytes[below((unsigned)size)] ^= (fmi2Byte)(1u << below(8));
            CHECK(f.deserialize(s->c, bytes, size, &copy));
            break;
        }
        case 2: {
            /* Overwrite one aligned double of the body with a hostile value (the header is left intact). */
            size_t slot = (size / sizeof(double)) > 1 ? 1 + below((unsigned)(size / sizeof(double) - 1)) : 0;
            double v = any_value();
            memcpy(bytes + slot * sizeof(double), &v, sizeof v);
            CHECK(f.deserialize(s->c, bytes, size, &copy));
            break;
        }
        default: CHECK(f.serialize(s->c, s->states[k], bytes, size - 1)); break;
        }
        if (copy && below(2)) {
            if (CHECK(f.set_state(s->c, copy)) == fmi2OK) {
                ok_restores++;
                s->stage = 3; /* the bytes may have been changed: reset before stepping on */
                read_outputs(s, __LINE__);
            }
        }
    }
    free(bytes);
    if (copy) CHECK(f.free_state(s->c, &copy));
}

/* A well-formed call for the stage the instance is believed to be in, so that sequences reach deep into stepping
 * between the random calls. */
static void lawful_call(Slot *s) {
    fmi2ValueReference vr[MAX_VR];
    fmi2Real values[MAX_VR];
    double h;
    int i;
    for (i = 0; i < n_in; i++) {
        vr[i] = (fmi2ValueReference)i;
        values[i] = (uniform() - 0.5) * 2.0;
    }
    switch (s->stage) {
    case 0:
        h = below(2) ? 0.0 : (uniform() - 0.5) * 100.0; /* the start time */
        CHECK(f.setup(s->c, fmi2False, 0.0, h, fmi2False, 0.0));
        if (CHECK(f.enter(s->c)) == fmi2OK) {
            s->stage = 1;
            s->t = h;
        }
        return;
    case 1:
        CHECK(f.set_real(s->c, vr, (size_t)n_in, values));
        s->stage = CHECK(f.exit_init(s->c)) == fmi2OK ? 2 : 3;
        return;
    case 2:
        CHECK(f.set_real(s->c, vr, (size_t)n_in, values));
        h = below(4) ? 1e-3 * (0.05 + 3.0 * uniform()) : 1e-3;
        if (CHECK(f.do_step(s->c, s->t, h, fmi2True)) == fmi2OK) {
            s->t += h;
            ok_steps++;
            read_outputs(s, __LINE__);
        } else {
            s->stage = 3;
        }
        return;
    default:
        if (CHECK(f.reset(s->c)) == fmi2OK) s->stage = 0;
        return;
    }
}

/* One random call on slot `s`. */
static void random_call(Slot *s) {
    fmi2ValueReference vr[MAX_VR], in_vr[MAX_VR];
    fmi2Real values[MAX_VR], out[MAX_VR];
    fmi2Integer order[MAX_VR];
    fmi2Boolean flags[MAX_VR];
    size_t n = below(4) == 0 ? 0 : 1 + below(n_in > 0 ? (unsigned)n_in : 1u);
    size_t i;
    int k;
    if (!s->c) {
        instantiate(s);
        return;
    }
    if (below(2)) {
        lawful_call(s);
        return;
    }
    switch (below(22)) {
    case 0:
        if (below(8) == 0) free_slot(s);
        return;
    case 1:
        CHECK(f.setup(s->c, (fmi2Boolean)below(2), any_value(), below(3) ? 0.0 : any_value(), (fmi2Boolean)below(2),
                      any_value()));
        return;
    case 2:
        if (CHECK(f.enter(s->c)) == fmi2OK) {
            fmi2Real t = 0.0;
            s->stage = 1;
            s->t = (CHECK(f.get_real_status(s->c, fmi2LastSuccessfulTime, &t)) == fmi2OK) ? t : 0.0;
        }
        return;
    case 3:
        if (CHECK(f.exit_init(s->c)) == fmi2OK) s->stage = 2;
        return;
    case 4:
        if (CHECK(f.terminate(s->c)) == fmi2OK) s->stage = 3;
        return;
    case 5:
        if (CHECK(f.reset(s->c)) == fmi2OK) s->stage = 0;
        s->t = 0.0;
        return;
    case 6: case 7: case 8:
        for (i = 0; i < n; i++) {
            vr[i] = pick_vr(0, n_in);
            values[i] = below(3) ? (uniform() - 0.5) * 2.0 : any_value();
        }
        CHECK(f.set_real(s->c, vr, n, values));
        return;
    case 9:
        for (i = 0; i < n; i++) vr[i] = pick_vr(0, n_reals);
        if (CHECK(f.get_real(s->c, vr, n, values)) == fmi2OK) {
            for (i = 0; i < n; i++) {
                if ((int)vr[i] >= n_in && (int)vr[i] < n_in + n_out && !isfinite(values[i])) {
                    fprintf(stderr, "seed %llu: output vr %u read %g\n", current_seed, vr[i], values[i]);
                    failures++;
                }
            }
        }
        return;
    case 10: read_outputs(s, __LINE__); return;
    case 11:
        for (i = 0; i < n; i++) {
            vr[i] = pick_vr(0, n_in);
            order[i] = below(4) ? 1 : (fmi2Integer)below(5) - 1;
            values[i] = below(3) ? uniform() - 0.5 : any_value();
        }
        if (CHECK(f.set_slopes(s->c, vr, n, order, values)) == fmi2OK && n > 0) ok_slopes++;
        return;
    case 12:
        vr[0] = (fmi2ValueReference)(n_in + n_out + (below(4) ? 0 : below(3)));
        CHECK(f.get_boolean(s->c, vr, 1, flags));
        CHECK(f.get_integer(s->c, vr, below(2), order));
        CHECK(f.get_boolean_status(s->c, (fmi2StatusKind)below(4), flags));
        return;
    case 13: CHECK(f.set_debug_logging(s->c, (fmi2Boolean)below(2), 0, NULL)); return;
    case 14: case 15: exercise_states(s); return;
    case 16:
        k = (int)below(2);
        if (s->states[k] && CHECK(f.set_state(s->c, s->states[k])) == fmi2OK) {
            s->t = s->state_t[k];
            s->stage = s->state_stage[k];
            read_outputs(s, __LINE__);
        }
        return;
    case 18: /* directional derivatives: mostly outputs by inputs; an OK result is finite */
        k = (int)below(3);
        for (i = 0; i < n; i++) {
            vr[i] = pick_vr(n_in, n_out);
            values[i] = below(4) ? uniform() - 0.5 : any_value();
        }
        for (i = 0; i < (size_t)k; i++) in_vr[i] = pick_vr(0, n_in);
        if (CHECK(f.derivative(s->c, vr, n, in_vr, (size_t)k, values, out)) == fmi2OK) {
            if (n > 0 && k > 0) ok_derivatives++;
            for (i = 0; i < n; i++) {
                if (!isfinite(out[i])) {
                    fprintf(stderr, "seed %llu: derivative of vr %u is %g\n", current_seed, vr[i], out[i]);
                    failures++;
                }
            }
        }
        return;
    case 17: /* calls with missing arrays must be refused, not followed */
        CHECK(f.get_real(s->c, NULL, 1 + below(3), values));
        CHECK(f.set_real(s->c, vr, 1, NULL));
        CHECK(f.get_state(s->c, NULL));
        CHECK(f.deserialize(s->c, NULL, 8, &s->states[0]));
        return;
    default: {
        double h = pick_step(), t = pick_point(s->t);
        if (CHECK(f.do_step(s->c, t, h, (fmi2Boolean)below(2))) == fmi2OK) {
            s->t = t + h;
            ok_steps++;
            read_outputs(s, __LINE__);
        }
        return;
    }
    }
}

/* Looks up `name`; exits with code 3 when the FMU lacks it. */
static void *symbol(void *lib, const char *name) {
    void *p = dlsym(lib, name);
    if (!p) {
        fprintf(stderr, "the FMU has no %s\n", name);
        exit(3);
    }
    return p;
}

#define FIND(field, name) *(void **)(&field) = symbol(lib, name)

int main(int argc, char **argv) {
    void *lib;
    Slot slots[SLOTS];
    unsigned long long seed;
    double seconds, start;
    long long sequences = 0, max_sequences;
    int j, i, fmi;
    if (argc != 10 || (strcmp(argv[1], "2") != 0 && strcmp(argv[1], "3") != 0)) {
        fprintf(stderr, "usage: %s FMI BINARY GUID N_INPUTS N_OUTPUTS N_REALS SEED SECONDS MAX_SEQUENCES\n", argv[0]);
        return 2;
    }
    fmi = atoi(argv[1]);
    argv++; /* the arguments after FMI as numbered before FMI 3 was added */
    guid = argv[2];
    n_in = atoi(argv[3]);
    n_out = atoi(argv[4]);
    n_reals = atoi(argv[5]);
    seed = strtoull(argv[6], NULL, 10);
    seconds = atof(argv[7]);
    max_sequences = atoll(argv[8]);
    if (n_in < 0 || n_in > MAX_VR || n_out < 0 || n_out > MAX_VR || n_reals < n_in + n_out) return 2;
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        return 3;
    }
    if (fmi == 2) {
        FIND(f.instantiate, "fmi2Instantiate");
        FIND(f.free_instance, "fmi2FreeInstance");
        FIND(f.set_debug_logging, "fmi2SetDebugLogging");
        FIND(f.setup, "fmi2SetupExperiment");
        FIND(f.enter, "fmi2EnterInitializationMode");
        FIND(f.exit_init, "fmi2ExitInitializationMode");
        FIND(f.terminate, "fmi2Terminate");
        FIND(f.reset, "fmi2Reset");
        FIND(f.get_real, "fmi2GetReal");
        FIND(f.set_real, "fmi2SetReal");
        FIND(f.get_boolean, "fmi2GetBoolean");
        FIND(f.get_integer, "fmi2GetInteger");
        FIND(f.set_slopes, "fmi2SetRealInputDerivatives");
        FIND(f.do_step, "fmi2DoStep");
        FIND(f.get_real_status, "fmi2GetRealStatus");
        FIND(f.get_boolean_status, "fmi2GetBooleanStatus");
        FIND(f.get_state, "fmi2GetFMUstate");
        FIND(f.set_state, "fmi2SetFMUstate");
        FIND(f.free_state, "fmi2FreeFMUstate");
        FIND(f.state_size, "fmi2SerializedFMUstateSize");
        FIND(f.serialize, "fmi2SerializeFMUstate");
        FIND(f.deserialize, "fmi2DeSerializeFMUstate");
        FIND(f.derivative, "fmi2GetDirectionalDerivative");
    } else {
        FIND(g.instantiate, "fmi3InstantiateCoSimulation");
        FIND(g.instantiate_me, "fmi3InstantiateModelExchange");
        FIND(g.free_instance, "fmi3FreeInstance");
        FIND(g.set_debug_logging, "fmi3SetDebugLogging");
        FIND(g.enter, "fmi3EnterInitializationMode");
        FIND(g.exit_init, "fmi3ExitInitializationMode");
        FIND(g.enter_event_mode, "fmi3EnterEventMode");
        FIND(g.terminate, "fmi3Terminate");
        FIND(g.reset, "fmi3Reset");
        FIND(g.get_float64, "fmi3GetFloat64");
        FIND(g.set_float64, "fmi3SetFloat64");
        FIND(g.get_boolean, "fmi3GetBoolean");
        FIND(g.get_int32, "fmi3GetInt32");
        FIND(g.get_output_derivatives, "fmi3GetOutputDerivatives");
        FIND(g.do_step, "fmi3DoStep");
        FIND(g.get_state, "fmi3GetFMUState");
        FIND(g.set_state, "fmi3SetFMUState");
        FIND(g.free_state, "fmi3FreeFMUState");
        FIND(g.state_size, "fmi3SerializedFMUStateSize");
        FIND(g.serialize, "fmi3SerializeFMUState");
        FIND(g.deserialize, "fmi3DeserializeFMUState");
        FIND(g.derivative, "fmi3GetDirectionalDerivative");
        f.instantiate = instantiate3;
        f.free_instance = free_instance3;
        f.set_debug_logging = set_debug_logging3;
        f.setup = setup3;
        f.enter = enter3;
        f.exit_init = exit_init3;
        f.terminate = terminate3;
        f.reset = reset3;
        f.get_real = get_real3;
        f.set_real = set_real3;
        f.get_boolean = get_boolean3;
        f.get_integer = get_integer3;
        f.set_slopes = set_slopes3;
        f.do_step = do_step3;
        f.get_real_status = get_real_status3;
        f.get_boolean_status = get_boolean_status3;
        f.get_state = get_state3;
        f.set_state = set_state3;
        f.free_state = free_state3;
        f.state_size = state_size3;
        f.serialize = serialize3;
        f.deserialize = deserialize3;
        f.derivative = derivative3;
    }

    start = now_s();
    while (sequences < max_sequences && now_s() - start < seconds && failures == 0) {
        current_seed = seed + (unsigned long long)sequences;
        rng_state = current_seed * 0x9E3779B97F4A7C15ULL + 1;
        fprintf(stderr, "sequence seed %llu\n", current_seed);
        memset(slots, 0, sizeof slots);
        for (j = 0; j < CALLS; j++) random_call(&slots[below(SLOTS)]);
        for (i = 0; i < SLOTS; i++) {
            if (slots[i].c) free_slot(&slots[i]);
        }
        sequences++;
    }
    dlclose(lib);
    printf("%lld sequences, %lld calls (%lld OK: %lld steps, %lld deserialised states restored, %lld input slopes, "
           "%lld directional derivatives), %lld log messages in %.1f s; %d invariant failures\n", sequences, calls,
           ok_calls, ok_steps, ok_restores, ok_slopes, ok_derivatives, logged, now_s() - start, failures);
    return failures == 0 ? 0 : 1;
}
