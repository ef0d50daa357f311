/* system_fmu.c: the FMI 2.0 co-simulation interface of a system FMU (`nnfmu system build`): the FMUs of an SSP system
 * packed under resources/fmus/<i>/, loaded when the system FMU is instantiated, and stepped by nnfmu's master in C
 * (inner_loop.c, the loop nnfmu's own Python master runs) at a fixed inner step h inside every doStep.
 *
 * What differs between systems lives in the generated system_config.h: the parts in stepping order with their value
 * references, the values row and unit conversions (the same plan the Python master builds), the connections for
 * initialisation, the drive inputs and the parameters the system FMU exposes. Inputs of the system FMU are the driven
 * element's free inputs (the drive), linear over a step: with the input derivatives a master sets
 * (canInterpolateInputs), else extrapolated from the drive of the step before (NS_EXTRAPOLATE_DRIVE) or held; outputs are every Real output of every part, in the master's row units. An inner FMU's failure becomes the
 * system FMU's, logged with the element's name.
 */
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Compiled alone: the FMI 2 interface, exported. Included by system_fmu3.c (NS_FMI3_GLUE): the same functions, static,
 * under its FMI 3 interface. */
#ifdef NS_FMI3_GLUE
#if defined(__GNUC__)
#define NS_FMI2_API static __attribute__((unused))
#else
#define NS_FMI2_API static
#endif
#include "fmi2FunctionTypes.h"
#else
#define NS_FMI2_API
#include "fmi2Functions.h"
#endif
#include "fmi3FunctionTypes.h"
#include "inner_loop.h"
#include "system_config.h"

/* The parts' libraries: dlopen on POSIX, LoadLibrary on Windows; their binaries/ folder on this platform, by FMI
 * version (FMI 2.0.4's and FMI 3's names). */
#ifdef _WIN32
#define WIN32_LEAN_AND_MEAN
#include <windows.h>
typedef HMODULE ns_library;
#define NS_LIBRARY_SUFFIX ".dll"
#define NS_FMI2_PLATFORM "win64"
#define NS_FMI3_PLATFORM "x86_64-windows"
#else
#include <dlfcn.h>
typedef void *ns_library;
#if defined(__APPLE__)
#define NS_LIBRARY_SUFFIX ".dylib"
#if defined(__aarch64__) || defined(__arm64__)
#define NS_FMI2_PLATFORM "aarch64-darwin"
#define NS_FMI3_PLATFORM "aarch64-darwin"
#else
#define NS_FMI2_PLATFORM "darwin64"
#define NS_FMI3_PLATFORM "x86_64-darwin"
#endif
#else
#define NS_LIBRARY_SUFFIX ".so"
#if defined(__aarch64__)
#define NS_FMI2_PLATFORM "aarch64-linux"
#define NS_FMI3_PLATFORM "aarch64-linux"
#else
#define NS_FMI2_PLATFORM "linux64"
#define NS_FMI3_PLATFORM "x86_64-linux"
#endif
#endif
#endif

#define NS_MESSAGE 1024        /* longest log message passed on, bytes */
#define NS_MAX_INNER_STEPS 1000000 /* most inner steps in one doStep */
#define NS_STEP_TOLERANCE 1e-6 /* how far (relative to h) a doStep may be off a whole number of inner steps */

typedef enum { NS_INSTANTIATED = 1, NS_INITIALIZATION = 2, NS_STEPPING = 4, NS_TERMINATED = 8, NS_FAILED = 16 } ns_mode;
#define NS_ANY (NS_INSTANTIATED | NS_INITIALIZATION | NS_STEPPING | NS_TERMINATED | NS_FAILED)

typedef struct ns_instance ns_instance;

/* One inner FMU: its shared library, its instance and the FMI functions the master calls beyond the loop's. */
typedef struct {
    ns_instance *owner;
    const ns_part_config *config;
    ns_library library;
    fmi2Component component;
    fmi2CallbackFunctions callbacks;
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *free_instance;
    fmi2SetupExperimentTYPE *setup_experiment;
    fmi2EnterInitializationModeTYPE *enter_initialization;
    fmi2ExitInitializationModeTYPE *exit_initialization;
    fmi2TerminateTYPE *terminate;
    fmi2ResetTYPE *reset;
    fmi2SetRealTYPE *set_real;
    fmi2GetRealTYPE *get_real;
    fmi2SetDebugLoggingTYPE *set_debug_logging;
    fmi2GetFMUstateTYPE *get_state; /* the state functions: NULL unless every part has them */
    fmi2SetFMUstateTYPE *set_state;
    fmi2FreeFMUstateTYPE *free_state;
    fmi2SerializedFMUstateSizeTYPE *serialized_size;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    /* An FMI 3 part: `component` points at the part itself and the functions above are adapters (fmi3_* below)
     * over its own functions here. */
    fmi3Instance instance3;
    double tolerance, stop_time; /* FMI 2's SetupExperiment, kept for FMI 3's EnterInitializationMode */
    int tolerance_defined, stop_time_defined;
    double start_time;
    fmi3InstantiateCoSimulationTYPE *instantiate3;
    fmi3FreeInstanceTYPE *free3;
    fmi3EnterInitializationModeTYPE *enter3;
    fmi3ExitInitializationModeTYPE *exit3;
    fmi3TerminateTYPE *terminate3;
    fmi3ResetTYPE *reset3;
    fmi3GetFloat64TYPE *get3;
    fmi3SetFloat64TYPE *set3;
    fmi3DoStepTYPE *step3;
    fmi3SetDebugLoggingTYPE *debug3;
    fmi3GetFMUStateTYPE *get_state3;
    fmi3SetFMUStateTYPE *set_state3;
    fmi3FreeFMUStateTYPE *free_state3;
    fmi3SerializedFMUStateSizeTYPE *size3;
    fmi3SerializeFMUStateTYPE *serialize3;
    fmi3DeserializeFMUStateTYPE *deserialize3;
} ns_part;

/* What evolves in the system FMU itself; a saved state is this and every part's own state. */
typedef struct {
    int64_t mode;
    int64_t steps_done;
    double start_time;
    double time;
    double drive[NS_N_DRIVE + 1];
    double slope[NS_N_DRIVE + 1];
    double previous[NS_N_DRIVE + 1];
    double previous_step;
    int64_t slopes_set;
    int64_t have_previous;
    double parameter[NS_N_PARAMETERS + 1];
    double rows[5 * NS_N_VALUES + 1]; /* values, now, before, estimate, fresh */
} ns_saved;

typedef struct {
    ns_saved own;
    fmi2FMUstate parts[NS_N_PARTS];
} ns_state;

#define NS_STATE_MAGIC "nnfmu-system-state-1"

struct ns_instance {
    char *name;
    fmi2CallbackFunctions outer;
    int logging_on;
    ns_mode mode;
    double start_time;
    double time;
    int64_t steps_done; /* inner steps since initialisation: the loop's step index */
    double drive[NS_N_DRIVE + 1];     /* inputs of the system FMU (the drive), in their declared units */
    double slope[NS_N_DRIVE + 1];     /* their derivatives over the coming step (0 unless set or extrapolated) */
    double previous[NS_N_DRIVE + 1];  /* the drive set before the previous step, and that step's size [s] */
    double previous_step;
    int64_t slopes_set;               /* the master set derivatives for the coming step */
    int64_t have_previous;            /* a step was taken since initialisation */
    double at_start[NS_N_DRIVE + 1];  /* the drive at an inner step's start and end */
    double at_end[NS_N_DRIVE + 1];
    double parameter[NS_N_PARAMETERS + 1];
    ns_part parts[NS_N_PARTS];
    nn_element elements[NS_N_PARTS];
    nn_plan plan;
    nn_failure failure;
    double *buffers; /* every array of the plan, one allocation */
};

static const char *const CALLS[] = {"set inputs", "set input slopes", "step", "get outputs", "refresh: set inputs",
                                    "refresh: get outputs"};

#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void say(const ns_instance *self, fmi2Status status, const char *format, ...) {
    char text[NS_MESSAGE];
    va_list args;
    if (self->outer.logger == NULL || (status < fmi2Warning && !self->logging_on)) return;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    self->outer.logger(self->outer.componentEnvironment, self->name, status,
                       status >= fmi2Error ? "logStatusError" : (status == fmi2Warning ? "logStatusWarning"
                                                                                        : "logEvents"),
                       "%s", text);
}

/* An inner FMU's log message, formatted and passed on with the element's name in front. */
static void part_logger(fmi2ComponentEnvironment environment, fmi2String instance_name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    const ns_part *part = (const ns_part *)environment;
    char text[NS_MESSAGE];
    size_t n;
    va_list args;
    (void)instance_name;
    if (part == NULL || part->owner->outer.logger == NULL || message == NULL) return;
    n = (size_t)snprintf(text, sizeof text, "element '%s': ", part->config->name);
    if (n >= sizeof text) n = sizeof text - 1;
    va_start(args, message);
    vsnprintf(text + n, sizeof text - n, message, args);
    va_end(args);
    /* Through "%s", as nnfmu's FMUs log: a '%' in a name is never read as a format. */
    part->owner->outer.logger(part->owner->outer.componentEnvironment, part->owner->name, status,
                              category ? category : "", "%s", text);
}

/* An FMI 3 part's log message (already formatted), passed on with the element's name in front. */
static void part_logger3(fmi3InstanceEnvironment environment, fmi3Status status, fmi3String category,
                         fmi3String message) {
    const ns_part *part = (const ns_part *)environment;
    char text[NS_MESSAGE];
    if (part == NULL || part->owner->outer.logger == NULL || message == NULL) return;
    snprintf(text, sizeof text, "element '%s': %s", part->config->name, message);
    part->owner->outer.logger(part->owner->outer.componentEnvironment, part->owner->name, (fmi2Status)status,
                              category ? category : "", "%s", text);
}

/* FMI 2 calls on an FMI 3 part (`c` is the ns_part): the master calls every part alike. */
static void fmi3_free(fmi2Component c) {
    ns_part *part = (ns_part *)c;
    if (part->instance3 != NULL) part->free3(part->instance3);
    part->instance3 = NULL;
}

static fmi2Status fmi3_setup(fmi2Component c, fmi2Boolean tolerance_defined, fmi2Real tolerance, fmi2Real start,
                             fmi2Boolean stop_defined, fmi2Real stop) {
    ns_part *part = (ns_part *)c;
    part->tolerance_defined = tolerance_defined != fmi2False;
    part->tolerance = tolerance;
    part->start_time = start;
    part->stop_time_defined = stop_defined != fmi2False;
    part->stop_time = stop;
    return fmi2OK;
}

static fmi2Status fmi3_enter(fmi2Component c) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->enter3(part->instance3, part->tolerance_defined, part->tolerance, part->start_time,
                                    part->stop_time_defined, part->stop_time);
}

static fmi2Status fmi3_exit(fmi2Component c) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->exit3(part->instance3);
}

static fmi2Status fmi3_terminate(fmi2Component c) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->terminate3(part->instance3);
}

static fmi2Status fmi3_reset(fmi2Component c) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->reset3(part->instance3);
}

static fmi2Status fmi3_set_real(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->set3(part->instance3, vr, n, value, n);
}

static fmi2Status fmi3_get_real(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->get3(part->instance3, vr, n, value, n);
}

static fmi2Status fmi3_debug(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String categories[]) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->debug3(part->instance3, on != fmi2False, n, categories);
}

static fmi2Status fmi3_get_state(fmi2Component c, fmi2FMUstate *state) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->get_state3(part->instance3, state);
}

static fmi2Status fmi3_set_state(fmi2Component c, fmi2FMUstate state) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->set_state3(part->instance3, state);
}

static fmi2Status fmi3_free_state(fmi2Component c, fmi2FMUstate *state) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->free_state3(part->instance3, state);
}

static fmi2Status fmi3_state_size(fmi2Component c, fmi2FMUstate state, size_t *size) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->size3(part->instance3, state, size);
}

static fmi2Status fmi3_serialize(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->serialize3(part->instance3, state, (fmi3Byte *)bytes, size);
}

static fmi2Status fmi3_deserialize(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    ns_part *part = (ns_part *)c;
    return (fmi2Status)part->deserialize3(part->instance3, (const fmi3Byte *)bytes, size, state);
}

/* The loop's calls on an FMI 3 part (inner_loop.h's signatures; `instance` is the ns_part). */
static int fmi3_loop_set(void *instance, const uint32_t *references, size_t n, double *values) {
    ns_part *part = (ns_part *)instance;
    return (int)part->set3(part->instance3, references, n, values, n);
}

static int fmi3_loop_get(void *instance, const uint32_t *references, size_t n, double *values) {
    ns_part *part = (ns_part *)instance;
    return (int)part->get3(part->instance3, references, n, values, n);
}

static int fmi3_loop_step(void *instance, double t, double h, int no_prior_state) {
    ns_part *part = (ns_part *)instance;
    fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
    fmi3Float64 reached = t;
    return (int)part->step3(part->instance3, t, h, no_prior_state != 0, &event, &terminate, &early, &reached);
}

static int allowed(ns_instance *self, const char *function, unsigned modes) {
    if (self == NULL) return 0;
    if (self->mode & modes) return 1;
    say(self, fmi2Error, "%s is not allowed in the current mode (%d)", function, (int)self->mode);
    return 0;
}

static fmi2Status part_failed(ns_instance *self, const ns_part *part, const char *call, fmi2Status status) {
    if (status <= fmi2Warning) return fmi2OK;
    say(self, status, "element '%s' (%s): %s returned status %d", part->config->name, part->config->folder, call,
        (int)status);
    self->mode = NS_FAILED;
    return status;
}

/* The path a `file:` URI names (percent escapes decoded), in a new string; NULL for another scheme. */
static char *uri_path(const char *uri) {
    const char *p;
    char *path, *out;
    if (uri == NULL || strncmp(uri, "file:", 5) != 0) return NULL;
    p = uri + 5;
    if (strncmp(p, "//", 2) == 0) {
        p += 2;
        if (strncmp(p, "localhost", 9) == 0) p += 9;
        if (*p != '/') return NULL; /* a host other than this one */
    }
    path = (char *)malloc(strlen(p) + 1);
    if (path == NULL) return NULL;
    for (out = path; *p; p++) {
        if (p[0] == '%' && isxdigit((unsigned char)p[1]) && isxdigit((unsigned char)p[2])) {
            char hex[3] = {p[1], p[2], 0};
            *out++ = (char)strtol(hex, NULL, 16);
            p += 2;
        } else {
            *out++ = *p;
        }
    }
    *out = 0;
#ifdef _WIN32
    if (path[0] == '/' && isalpha((unsigned char)path[1]) && path[2] == ':') memmove(path, path + 1, strlen(path));
#endif
    return path;
}

/* The library at `path`, or NULL (with the reason in `why`, `size` bytes). */
static ns_library library_open(const char *path, char *why, size_t size) {
#ifdef _WIN32
    char *native = (char *)malloc(strlen(path) + 1), *p;
    ns_library library;
    if (native == NULL) {
        snprintf(why, size, "out of memory");
        return NULL;
    }
    strcpy(native, path);
    for (p = native; *p; p++)
        if (*p == '/') *p = '\\';
    library = LoadLibraryA(native);
    if (library == NULL) snprintf(why, size, "Windows error %lu", (unsigned long)GetLastError());
    free(native);
    return library;
#else
    ns_library library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (library == NULL) snprintf(why, size, "%s", dlerror());
    return library;
#endif
}

static void *library_symbol(ns_library library, const char *name) {
#ifdef _WIN32
    return (void *)GetProcAddress(library, name);
#else
    return dlsym(library, name);
#endif
}

static void library_close(ns_library library) {
#ifdef _WIN32
    FreeLibrary(library);
#else
    dlclose(library);
#endif
}

/* `base` (without its trailing slashes) + "/" + each of the parts, in a new string. */
static char *joined(const char *base, const char *a, const char *b, const char *c) {
    size_t n = strlen(base);
    char *text;
    while (n > 0 && base[n - 1] == '/') n--;
    text = (char *)malloc(n + strlen(a) + strlen(b) + strlen(c) + 4);
    if (text == NULL) return NULL;
    memcpy(text, base, n);
    sprintf(text + n, "/%s%s%s", a, b, c);
    return text;
}

static void *symbol(ns_instance *self, ns_part *part, const char *name) {
    void *found = library_symbol(part->library, name);
    if (found == NULL) say(self, fmi2Error, "element '%s' (%s): no function %s", part->config->name, part->config->folder, name);
    return found;
}

/* An FMI 2 part's functions; 0 when it has them all. */
static int load_fmi2(ns_instance *self, ns_part *part) {
    part->instantiate = (fmi2InstantiateTYPE *)symbol(self, part, "fmi2Instantiate");
    part->free_instance = (fmi2FreeInstanceTYPE *)symbol(self, part, "fmi2FreeInstance");
    part->setup_experiment = (fmi2SetupExperimentTYPE *)symbol(self, part, "fmi2SetupExperiment");
    part->enter_initialization = (fmi2EnterInitializationModeTYPE *)symbol(self, part, "fmi2EnterInitializationMode");
    part->exit_initialization = (fmi2ExitInitializationModeTYPE *)symbol(self, part, "fmi2ExitInitializationMode");
    part->terminate = (fmi2TerminateTYPE *)symbol(self, part, "fmi2Terminate");
    part->reset = (fmi2ResetTYPE *)symbol(self, part, "fmi2Reset");
    part->set_real = (fmi2SetRealTYPE *)symbol(self, part, "fmi2SetReal");
    part->get_real = (fmi2GetRealTYPE *)symbol(self, part, "fmi2GetReal");
    part->set_debug_logging = (fmi2SetDebugLoggingTYPE *)symbol(self, part, "fmi2SetDebugLogging");
    if (NS_CAN_GET_AND_SET_STATE) {
        part->get_state = (fmi2GetFMUstateTYPE *)symbol(self, part, "fmi2GetFMUstate");
        part->set_state = (fmi2SetFMUstateTYPE *)symbol(self, part, "fmi2SetFMUstate");
        part->free_state = (fmi2FreeFMUstateTYPE *)symbol(self, part, "fmi2FreeFMUstate");
        if (!(part->get_state && part->set_state && part->free_state)) return 1;
    }
    if (NS_CAN_SERIALIZE_STATE) {
        part->serialized_size = (fmi2SerializedFMUstateSizeTYPE *)symbol(self, part, "fmi2SerializedFMUstateSize");
        part->serialize = (fmi2SerializeFMUstateTYPE *)symbol(self, part, "fmi2SerializeFMUstate");
        part->deserialize = (fmi2DeSerializeFMUstateTYPE *)symbol(self, part, "fmi2DeSerializeFMUstate");
        if (!(part->serialized_size && part->serialize && part->deserialize)) return 1;
    }
    return !(part->instantiate && part->free_instance && part->setup_experiment && part->enter_initialization &&
             part->exit_initialization && part->terminate && part->reset && part->set_real && part->get_real &&
             part->set_debug_logging);
}

/* An FMI 3 part's functions, and the FMI 2 adapters over them; 0 when it has them all. */
static int load_fmi3(ns_instance *self, ns_part *part) {
    part->instantiate3 = (fmi3InstantiateCoSimulationTYPE *)symbol(self, part, "fmi3InstantiateCoSimulation");
    part->free3 = (fmi3FreeInstanceTYPE *)symbol(self, part, "fmi3FreeInstance");
    part->enter3 = (fmi3EnterInitializationModeTYPE *)symbol(self, part, "fmi3EnterInitializationMode");
    part->exit3 = (fmi3ExitInitializationModeTYPE *)symbol(self, part, "fmi3ExitInitializationMode");
    part->terminate3 = (fmi3TerminateTYPE *)symbol(self, part, "fmi3Terminate");
    part->reset3 = (fmi3ResetTYPE *)symbol(self, part, "fmi3Reset");
    part->get3 = (fmi3GetFloat64TYPE *)symbol(self, part, "fmi3GetFloat64");
    part->set3 = (fmi3SetFloat64TYPE *)symbol(self, part, "fmi3SetFloat64");
    part->step3 = (fmi3DoStepTYPE *)symbol(self, part, "fmi3DoStep");
    part->debug3 = (fmi3SetDebugLoggingTYPE *)symbol(self, part, "fmi3SetDebugLogging");
    part->free_instance = fmi3_free;
    part->setup_experiment = fmi3_setup;
    part->enter_initialization = fmi3_enter;
    part->exit_initialization = fmi3_exit;
    part->terminate = fmi3_terminate;
    part->reset = fmi3_reset;
    part->set_real = fmi3_set_real;
    part->get_real = fmi3_get_real;
    part->set_debug_logging = fmi3_debug;
    if (NS_CAN_GET_AND_SET_STATE) {
        part->get_state3 = (fmi3GetFMUStateTYPE *)symbol(self, part, "fmi3GetFMUState");
        part->set_state3 = (fmi3SetFMUStateTYPE *)symbol(self, part, "fmi3SetFMUState");
        part->free_state3 = (fmi3FreeFMUStateTYPE *)symbol(self, part, "fmi3FreeFMUState");
        if (!(part->get_state3 && part->set_state3 && part->free_state3)) return 1;
        part->get_state = fmi3_get_state;
        part->set_state = fmi3_set_state;
        part->free_state = fmi3_free_state;
    }
    if (NS_CAN_SERIALIZE_STATE) {
        part->size3 = (fmi3SerializedFMUStateSizeTYPE *)symbol(self, part, "fmi3SerializedFMUStateSize");
        part->serialize3 = (fmi3SerializeFMUStateTYPE *)symbol(self, part, "fmi3SerializeFMUState");
        part->deserialize3 = (fmi3DeserializeFMUStateTYPE *)symbol(self, part, "fmi3DeserializeFMUState");
        if (!(part->size3 && part->serialize3 && part->deserialize3)) return 1;
        part->serialized_size = fmi3_state_size;
        part->serialize = fmi3_serialize;
        part->deserialize = fmi3_deserialize;
    }
    return !(part->instantiate3 && part->free3 && part->enter3 && part->exit3 && part->terminate3 && part->reset3 &&
             part->get3 && part->set3 && part->step3 && part->debug3);
}

/* Open the part's library and take its functions; 0 on success. */
static int load_part(ns_instance *self, ns_part *part, const char *folder) {
    const ns_part_config *c = part->config;
    char *path = joined(folder, c->folder, "/binaries/", c->fmi_version == 3 ? NS_FMI3_PLATFORM : NS_FMI2_PLATFORM);
    char *library, why[NS_MESSAGE];
    if (path == NULL) return 1;
    library = (char *)malloc(strlen(path) + strlen(c->identifier) + strlen(NS_LIBRARY_SUFFIX) + 2);
    if (library == NULL) {
        free(path);
        return 1;
    }
    sprintf(library, "%s/%s%s", path, c->identifier, NS_LIBRARY_SUFFIX);
    free(path);
    part->library = library_open(library, why, sizeof why);
    if (part->library == NULL) {
        say(self, fmi2Error, "element '%s': cannot load %s: %s", c->name, library, why);
        free(library);
        return 1;
    }
    free(library);
    return c->fmi_version == 3 ? load_fmi3(self, part) : load_fmi2(self, part);
}

/* The loop's element for part i: its buffers carved from `next`, its functions from the part's library. */
static double *wire_element(ns_instance *self, int64_t i, double *next) {
    const ns_part_config *c = self->parts[i].config;
    nn_element *e = &self->elements[i];
    e->instance = self->parts[i].component;
    if (c->fmi_version == 3) {
        e->set_real = fmi3_loop_set;
        e->get_real = fmi3_loop_get;
        e->do_step = fmi3_loop_step;
        e->set_slopes = NULL; /* FMI 3 co-simulation takes no input derivatives */
    } else {
        e->set_real = (nn_transfer)library_symbol(self->parts[i].library, "fmi2SetReal");
        e->get_real = (nn_transfer)library_symbol(self->parts[i].library, "fmi2GetReal");
        e->do_step = (nn_do_step)library_symbol(self->parts[i].library, "fmi2DoStep");
        e->set_slopes =
            c->takes_slopes ? (nn_set_slopes)library_symbol(self->parts[i].library, "fmi2SetRealInputDerivatives") : NULL;
    }
    e->input_references = c->input_references;
    e->n_coupled = c->n_coupled;
    e->n_driven = c->n_driven;
    e->sources = c->sources;
    e->slope_references = c->input_references;
    e->slope_orders = c->slope_orders;
    e->output_references = c->output_references;
    e->n_outputs = c->n_outputs;
    e->span_start = c->span_start;
    e->is_driven = c->is_driven;
    e->feedthrough = c->feedthrough;
    e->in_scale = c->in_scale;
    e->in_offset = c->in_offset;
    e->out_scale = c->out_scale;
    e->out_offset = c->out_offset;
    e->inputs = next;
    next += c->n_coupled + c->n_driven;
    e->slopes = next;
    next += c->n_coupled + c->n_driven;
    return next;
}

/* Every part's SSD parameter values and the system FMU's parameters back at their start values. */
static fmi2Status apply_parameters(ns_instance *self) {
    int64_t i;
    for (i = 0; i < NS_N_PARAMETERS; i++) {
        const ns_parameter_config *p = &NS_PARAMETERS[i];
        ns_part *part = &self->parts[p->part];
        fmi2Status status;
        self->parameter[i] = p->start;
        if (!p->bound) continue;
        status = part->set_real(part->component, &p->reference, 1, &p->start);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2SetReal (its SSD parameter value)", status);
    }
    return fmi2OK;
}

static void free_instance(ns_instance *self) {
    int64_t i;
    if (self == NULL) return;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        if (part->component != NULL && part->free_instance != NULL) part->free_instance(part->component);
        if (part->library != NULL) library_close(part->library);
    }
    free(self->buffers);
    free(self->name);
    free(self);
}

#ifndef NS_FMI3_GLUE
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }
#endif

NS_FMI2_API fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    ns_instance *self;
    char *folder;
    double *next;
    int64_t i, size = 5 * (int64_t)NS_N_VALUES;
    (void)visible;
    if (functions == NULL) return NULL;
    self = (ns_instance *)calloc(1, sizeof(ns_instance));
    if (self == NULL) return NULL;
    self->outer = *functions;
    self->logging_on = loggingOn != fmi2False;
    self->name = (char *)malloc(strlen(instanceName ? instanceName : "") + 1);
    if (self->name == NULL) {
        free(self);
        return NULL;
    }
    strcpy(self->name, instanceName ? instanceName : "");
    if (fmuType != fmi2CoSimulation) {
        say(self, fmi2Error, "fmi2Instantiate: %s supports co-simulation only", NS_MODEL_IDENTIFIER);
        free_instance(self);
        return NULL;
    }
    if (fmuGUID == NULL || strcmp(fmuGUID, NS_GUID) != 0) {
        say(self, fmi2Error, "fmi2Instantiate: GUID %s is not this FMU's (%s)", fmuGUID ? fmuGUID : "(none)", NS_GUID);
        free_instance(self);
        return NULL;
    }
    folder = uri_path(fmuResourceLocation);
    if (folder == NULL) {
        say(self, fmi2Error, "fmi2Instantiate: the resource location %s is not a local file: URI, and the system's "
            "FMUs lie there", fmuResourceLocation ? fmuResourceLocation : "(none)");
        free_instance(self);
        return NULL;
    }
    for (i = 0; i < NS_N_PARTS; i++) size += 2 * (NS_PARTS[i].n_coupled + NS_PARTS[i].n_driven);
    self->buffers = (double *)calloc((size_t)size + 1, sizeof(double));
    if (self->buffers == NULL) {
        free(folder);
        free_instance(self);
        return NULL;
    }
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        char *resources;
        part->owner = self;
        part->config = &NS_PARTS[i];
        if (load_part(self, part, folder)) {
            free(folder);
            free_instance(self);
            return NULL;
        }
        if (part->config->fmi_version == 3) { /* a path with a trailing separator */
            resources = joined(folder, part->config->folder, "/resources/", "");
            if (resources == NULL) {
                free(folder);
                free_instance(self);
                return NULL;
            }
            part->instance3 = part->instantiate3(part->config->name, part->config->guid, resources, fmi3False,
                                                 loggingOn != fmi2False, fmi3False, fmi3False, NULL, 0, part,
                                                 part_logger3, NULL);
            part->component = part->instance3 != NULL ? (fmi2Component)part : NULL;
        } else { /* a URI */
            part->callbacks.logger = part_logger;
            part->callbacks.allocateMemory = functions->allocateMemory ? functions->allocateMemory : calloc;
            part->callbacks.freeMemory = functions->freeMemory ? functions->freeMemory : free;
            part->callbacks.stepFinished = NULL;
            part->callbacks.componentEnvironment = part;
            resources = joined(fmuResourceLocation, part->config->folder, "/resources", "");
            if (resources == NULL) {
                free(folder);
                free_instance(self);
                return NULL;
            }
            part->component = part->instantiate(part->config->name, fmi2CoSimulation, part->config->guid, resources,
                                                &part->callbacks, fmi2False, loggingOn);
        }
        free(resources);
        if (part->component == NULL) {
            say(self, fmi2Error, "element '%s' (%s): fmi2Instantiate failed", part->config->name,
                part->config->folder);
            free(folder);
            free_instance(self);
            return NULL;
        }
    }
    free(folder);
    next = self->buffers;
    self->plan.values = next;
    self->plan.now = next + NS_N_VALUES;
    self->plan.before = next + 2 * NS_N_VALUES;
    self->plan.estimate = next + 3 * NS_N_VALUES;
    self->plan.fresh = next + 4 * NS_N_VALUES;
    next += 5 * NS_N_VALUES;
    for (i = 0; i < NS_N_PARTS; i++) next = wire_element(self, i, next);
    self->plan.elements = self->elements;
    self->plan.n_elements = NS_N_PARTS;
    self->plan.group_starts = NS_GROUP_STARTS;
    self->plan.n_groups = NS_N_GROUPS;
    self->plan.refreshed = NS_REFRESHED;
    self->plan.n_refreshed = NS_N_REFRESHED;
    self->plan.n_values = NS_N_VALUES;
    self->plan.n_drive = NS_N_DRIVE;
    self->plan.linear_extrapolation = NS_LINEAR_EXTRAPOLATION;
    self->plan.gauss_seidel = NS_GAUSS_SEIDEL;
    self->mode = NS_INSTANTIATED;
    if (apply_parameters(self) != fmi2OK) {
        free_instance(self);
        return NULL;
    }
    return self;
}

NS_FMI2_API void fmi2FreeInstance(fmi2Component c) { free_instance((ns_instance *)c); }

NS_FMI2_API fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    ns_instance *self = (ns_instance *)c;
    int64_t i;
    fmi2Status worst = fmi2OK;
    if (!allowed(self, "fmi2SetDebugLogging", NS_ANY)) return fmi2Error;
    self->logging_on = loggingOn != fmi2False;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->set_debug_logging(part->component, loggingOn, nCategories, categories);
        if (status > worst) worst = status;
    }
    return worst > fmi2Warning ? fmi2Warning : worst; /* a part refusing categories does not fail the system */
}

NS_FMI2_API fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    ns_instance *self = (ns_instance *)c;
    int64_t i;
    if (!allowed(self, "fmi2SetupExperiment", NS_INSTANTIATED)) return fmi2Error;
    if (!isfinite(startTime)) {
        say(self, fmi2Error, "fmi2SetupExperiment: start time %g is not finite", startTime);
        return fmi2Error;
    }
    self->start_time = self->time = startTime;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->setup_experiment(part->component, toleranceDefined, tolerance, startTime,
                                                   stopTimeDefined, stopTime);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2SetupExperiment", status);
    }
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    ns_instance *self = (ns_instance *)c;
    int64_t i;
    if (!allowed(self, "fmi2EnterInitializationMode", NS_INSTANTIATED)) return fmi2Error;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->enter_initialization(part->component);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2EnterInitializationMode", status);
    }
    self->mode = NS_INITIALIZATION;
    return fmi2OK;
}

/* What the master does at t0 (master.py: _System.initialise): the drive into the driven part, the connections passed
 * as often as there are parts, initialisation ended, every output read, the refresh, and t0 as both t_n and t_{n-1}. */
NS_FMI2_API fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    ns_instance *self = (ns_instance *)c;
    int64_t i, pass;
    fmi2Status status;
    if (!allowed(self, "fmi2ExitInitializationMode", NS_INITIALIZATION)) return fmi2Error;
    for (i = 0; i < NS_N_PARTS; i++) {
        const ns_part_config *config = &NS_PARTS[i];
        ns_part *part = &self->parts[i];
        int64_t k;
        double value[NS_N_DRIVE + 1];
        if (!config->is_driven || config->n_driven == 0) continue;
        for (k = 0; k < config->n_driven; k++) {
            int64_t at = config->n_coupled + k;
            value[k] = config->in_scale ? config->in_scale[at] * self->drive[k] + config->in_offset[at]
                                        : self->drive[k];
        }
        status = part->set_real(part->component, config->input_references + config->n_coupled,
                                (size_t)config->n_driven, value);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2SetReal (the drive at the start)", status);
    }
    for (pass = 0; pass < NS_N_PARTS; pass++) {
        for (i = 0; i < NS_N_LINKS; i++) {
            const ns_link_config *link = &NS_LINKS[i];
            ns_part *from = &self->parts[link->source], *to = &self->parts[link->target];
            double value;
            status = from->get_real(from->component, &link->output, 1, &value);
            if (status > fmi2Warning) return part_failed(self, from, "fmi2GetReal (initialisation)", status);
            value = link->a * (link->s * value + link->o) + link->b;
            status = to->set_real(to->component, &link->input, 1, &value);
            if (status > fmi2Warning) return part_failed(self, to, "fmi2SetReal (initialisation)", status);
        }
    }
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        status = part->exit_initialization(part->component);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2ExitInitializationMode", status);
    }
    for (i = 0; i < NS_N_PARTS; i++) {
        const nn_element *e = &self->elements[i];
        double *span = self->plan.values + e->span_start;
        int64_t k;
        status = (fmi2Status)e->get_real(e->instance, e->output_references, (size_t)e->n_outputs, span);
        if (status > fmi2Warning) return part_failed(self, &self->parts[i], "fmi2GetReal (outputs at the start)", status);
        if (e->out_scale != NULL)
            for (k = 0; k < e->n_outputs; k++) {
                span[k] *= e->out_scale[k];
                span[k] += e->out_offset[k];
            }
    }
    if (nn_cosim_refresh(&self->plan, self->drive, &self->failure)) {
        ns_part *part = &self->parts[self->failure.element];
        return part_failed(self, part, CALLS[self->failure.call], (fmi2Status)self->failure.status);
    }
    memcpy(self->plan.now, self->plan.values, NS_N_VALUES * sizeof(double));
    memcpy(self->plan.before, self->plan.values, NS_N_VALUES * sizeof(double));
    self->steps_done = 0;
    self->have_previous = 0;
    self->mode = NS_STEPPING;
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    ns_instance *self = (ns_instance *)c;
    double h = communicationStepSize, inner, exact;
    int64_t m, k, i;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!allowed(self, "fmi2DoStep", NS_STEPPING)) return fmi2Error;
    exact = h / NS_INNER_STEP;
    if (!(h > 0.0) || !isfinite(h) || !(exact < NS_MAX_INNER_STEPS + 0.5)) {
        say(self, fmi2Error, "fmi2DoStep(t = %.9g s, h = %.9g s): the step must be positive and at most %d inner "
            "steps of %.9g s", currentCommunicationPoint, h, NS_MAX_INNER_STEPS, NS_INNER_STEP);
        return fmi2Error;
    }
    m = (int64_t)floor(exact + 0.5);
    if (m < 1 || fabs((double)m - exact) > NS_STEP_TOLERANCE) {
        say(self, fmi2Error, "fmi2DoStep(t = %.9g s, h = %.9g s): the step is not a whole number of the system's "
            "inner steps of %.9g s (it is %.9g of them)", currentCommunicationPoint, h, NS_INNER_STEP, exact);
        return fmi2Error;
    }
    inner = h / (double)m;
    if (NS_EXTRAPOLATE_DRIVE && !self->slopes_set && self->have_previous)
        for (i = 0; i < NS_N_DRIVE; i++) self->slope[i] = (self->drive[i] - self->previous[i]) / self->previous_step;
    for (k = 0; k < m; k++) {
        double t = currentCommunicationPoint + (double)k * inner;
        for (i = 0; i < NS_N_DRIVE; i++) {
            self->at_start[i] = self->drive[i] + self->slope[i] * ((double)k * inner);
            self->at_end[i] = self->drive[i] + self->slope[i] * ((double)(k + 1) * inner);
        }
        if (nn_cosim_step(&self->plan, self->steps_done, t, inner, self->at_start, self->at_end, &self->failure)) {
            ns_part *part = &self->parts[self->failure.element];
            say(self, fmi2Error, "element '%s' (%s): %s failed with status %d in the inner step from t = %.9g s "
                "(h = %.9g s)", part->config->name, part->config->folder, CALLS[self->failure.call],
                (int)self->failure.status, t, inner);
            self->mode = NS_FAILED;
            return self->failure.status >= fmi2Fatal ? fmi2Fatal : fmi2Error;
        }
        self->steps_done++;
    }
    memcpy(self->previous, self->drive, sizeof self->previous);
    self->previous_step = h;
    self->have_previous = 1;
    self->slopes_set = 0;
    memset(self->slope, 0, sizeof self->slope);
    self->time = currentCommunicationPoint + h;
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2Terminate(fmi2Component c) {
    ns_instance *self = (ns_instance *)c;
    int64_t i;
    fmi2Status worst = fmi2OK;
    if (!allowed(self, "fmi2Terminate", NS_STEPPING | NS_FAILED)) return fmi2Error;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->terminate(part->component);
        if (status > worst) worst = status;
    }
    self->mode = NS_TERMINATED;
    return worst > fmi2Warning ? fmi2Warning : worst;
}

NS_FMI2_API fmi2Status fmi2Reset(fmi2Component c) {
    ns_instance *self = (ns_instance *)c;
    int64_t i;
    if (!allowed(self, "fmi2Reset", NS_ANY)) return fmi2Error;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->reset(part->component);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2Reset", status);
    }
    memset(self->drive, 0, sizeof self->drive);
    memset(self->slope, 0, sizeof self->slope);
    self->slopes_set = self->have_previous = 0;
    memset(self->plan.values, 0, 5 * NS_N_VALUES * sizeof(double));
    self->steps_done = 0;
    self->time = self->start_time;
    self->mode = NS_INSTANTIATED;
    return apply_parameters(self);
}

NS_FMI2_API fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    ns_instance *self = (ns_instance *)c;
    size_t i;
    if (!allowed(self, "fmi2GetReal", NS_ANY)) return fmi2Error;
    if (nvr > 0 && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        fmi2ValueReference r = vr[i];
        if (r < NS_VR_OUTPUTS) {
            value[i] = self->drive[r];
        } else if (r < NS_VR_PARAMETERS) {
            value[i] = self->plan.values[r - NS_VR_OUTPUTS];
        } else if (r < NS_VR_END) {
            value[i] = self->parameter[r - NS_VR_PARAMETERS];
        } else {
            say(self, fmi2Error, "fmi2GetReal: no Real variable has value reference %u", (unsigned)r);
            return fmi2Error;
        }
    }
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    ns_instance *self = (ns_instance *)c;
    size_t i;
    if (!allowed(self, "fmi2SetReal", NS_INSTANTIATED | NS_INITIALIZATION | NS_STEPPING)) return fmi2Error;
    if (nvr > 0 && (vr == NULL || value == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        fmi2ValueReference r = vr[i];
        if (!isfinite(value[i])) {
            say(self, fmi2Error, "fmi2SetReal: value reference %u refused: %g is not finite", (unsigned)r, value[i]);
            return fmi2Error;
        }
        if (r < NS_VR_OUTPUTS) {
            self->drive[r] = value[i];
        } else if (r >= NS_VR_PARAMETERS && r < NS_VR_END && (self->mode & (NS_INSTANTIATED | NS_INITIALIZATION))) {
            const ns_parameter_config *p = &NS_PARAMETERS[r - NS_VR_PARAMETERS];
            ns_part *part = &self->parts[p->part];
            fmi2Status status = part->set_real(part->component, &p->reference, 1, &value[i]);
            if (status > fmi2Warning) {
                say(self, status, "element '%s': parameter value %g refused (status %d)", part->config->name,
                    value[i], (int)status);
                return status;
            }
            self->parameter[r - NS_VR_PARAMETERS] = value[i];
        } else {
            say(self, fmi2Error, "fmi2SetReal: value reference %u is no input%s", (unsigned)r,
                r >= NS_VR_PARAMETERS && r < NS_VR_END ? " (parameters are fixed once initialisation ends)"
                                                       : " or parameter");
            return fmi2Error;
        }
    }
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    ns_instance *self = (ns_instance *)c;
    size_t i;
    if (!allowed(self, "fmi2SetRealInputDerivatives", NS_INITIALIZATION | NS_STEPPING)) return fmi2Error;
    if (nvr > 0 && (vr == NULL || value == NULL || order == NULL)) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        if (vr[i] >= NS_VR_OUTPUTS || order[i] != 1 || !isfinite(value[i])) {
            say(self, fmi2Error, "fmi2SetRealInputDerivatives: value reference %u, order %d, value %g refused: first "
                "derivatives (finite) of inputs only", (unsigned)vr[i], (int)order[i], value[i]);
            return fmi2Error;
        }
        self->slope[vr[i]] = value[i];
        self->slopes_set = 1;
    }
    return fmi2OK;
}

static fmi2Status unsupported(fmi2Component c, const char *function) {
    ns_instance *self = (ns_instance *)c;
    if (self != NULL) say(self, fmi2Error, "%s is not supported by this system FMU", function);
    return fmi2Error;
}

static fmi2Status none_or_unsupported(fmi2Component c, size_t n, const char *function) {
    return n == 0 ? fmi2OK : unsupported(c, function);
}

NS_FMI2_API fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2GetInteger (no Integer variables)");
}

NS_FMI2_API fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2GetBoolean (no Boolean variables)");
}

NS_FMI2_API fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2GetString (no String variables)");
}

NS_FMI2_API fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2SetInteger (no Integer variables)");
}

NS_FMI2_API fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2SetBoolean (no Boolean variables)");
}

NS_FMI2_API fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr;
    (void)value;
    return none_or_unsupported(c, nvr, "fmi2SetString (no String variables)");
}

static void save_own(const ns_instance *self, ns_saved *own) {
    own->mode = (int64_t)self->mode;
    own->steps_done = self->steps_done;
    own->start_time = self->start_time;
    own->time = self->time;
    memcpy(own->drive, self->drive, sizeof own->drive);
    memcpy(own->slope, self->slope, sizeof own->slope);
    memcpy(own->previous, self->previous, sizeof own->previous);
    own->previous_step = self->previous_step;
    own->slopes_set = self->slopes_set;
    own->have_previous = self->have_previous;
    memcpy(own->parameter, self->parameter, sizeof own->parameter);
    memcpy(own->rows, self->plan.values, 5 * NS_N_VALUES * sizeof(double));
}

static void restore_own(ns_instance *self, const ns_saved *own) {
    self->mode = (ns_mode)own->mode;
    self->steps_done = own->steps_done;
    self->start_time = own->start_time;
    self->time = own->time;
    memcpy(self->drive, own->drive, sizeof own->drive);
    memcpy(self->slope, own->slope, sizeof own->slope);
    memcpy(self->previous, own->previous, sizeof own->previous);
    self->previous_step = own->previous_step;
    self->slopes_set = own->slopes_set;
    self->have_previous = own->have_previous;
    memcpy(self->parameter, own->parameter, sizeof own->parameter);
    memcpy(self->plan.values, own->rows, 5 * NS_N_VALUES * sizeof(double));
}

static int states_supported(ns_instance *self, const char *function) {
    if (NS_CAN_GET_AND_SET_STATE) return 1;
    say(self, fmi2Error, "%s: a part of this system cannot get and set its FMU state, so neither can the system",
        function);
    return 0;
}

/* The system's state: its own fields and every part's state (each part reuses its earlier state in place). */
NS_FMI2_API fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ns_instance *self = (ns_instance *)c;
    ns_state *state;
    int64_t i;
    if (!allowed(self, "fmi2GetFMUstate", NS_INSTANTIATED | NS_INITIALIZATION | NS_STEPPING | NS_TERMINATED) ||
        !states_supported(self, "fmi2GetFMUstate") || FMUstate == NULL)
        return fmi2Error;
    state = (ns_state *)*FMUstate;
    if (state == NULL) {
        state = (ns_state *)calloc(1, sizeof(ns_state));
        if (state == NULL) {
            say(self, fmi2Error, "fmi2GetFMUstate: out of memory");
            return fmi2Error;
        }
        *FMUstate = state;
    }
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->get_state(part->component, &state->parts[i]);
        if (status > fmi2Warning) {
            say(self, status, "element '%s' (%s): fmi2GetFMUstate returned status %d", part->config->name,
                part->config->folder, (int)status);
            return status;
        }
    }
    save_own(self, &state->own);
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    ns_instance *self = (ns_instance *)c;
    const ns_state *state = (const ns_state *)FMUstate;
    int64_t i;
    if (!allowed(self, "fmi2SetFMUstate", NS_ANY) || !states_supported(self, "fmi2SetFMUstate")) return fmi2Error;
    if (state == NULL) {
        say(self, fmi2Error, "fmi2SetFMUstate: no state given");
        return fmi2Error;
    }
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->set_state(part->component, state->parts[i]);
        if (status > fmi2Warning) return part_failed(self, part, "fmi2SetFMUstate", status);
    }
    restore_own(self, &state->own);
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    ns_instance *self = (ns_instance *)c;
    ns_state *state;
    int64_t i;
    if (!allowed(self, "fmi2FreeFMUstate", NS_ANY) || !states_supported(self, "fmi2FreeFMUstate")) return fmi2Error;
    if (FMUstate == NULL || *FMUstate == NULL) return fmi2OK;
    state = (ns_state *)*FMUstate;
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        if (state->parts[i] != NULL) part->free_state(part->component, &state->parts[i]);
    }
    free(state);
    *FMUstate = NULL;
    return fmi2OK;
}

/* Serialised: the magic text, the system's own fields, then per part its size (uint64_t) and its bytes. */
static int serializable(ns_instance *self, const char *function) {
    if (NS_CAN_SERIALIZE_STATE) return 1;
    say(self, fmi2Error, "%s: a part of this system cannot serialise its FMU state, so neither can the system",
        function);
    return 0;
}

static fmi2Status part_sizes(ns_instance *self, const ns_state *state, size_t sizes[], size_t *total) {
    int64_t i;
    *total = sizeof NS_STATE_MAGIC + sizeof(ns_saved);
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        fmi2Status status = part->serialized_size(part->component, state->parts[i], &sizes[i]);
        if (status > fmi2Warning) {
            say(self, status, "element '%s': fmi2SerializedFMUstateSize returned status %d", part->config->name,
                (int)status);
            return status;
        }
        *total += sizeof(uint64_t) + sizes[i];
    }
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    ns_instance *self = (ns_instance *)c;
    size_t sizes[NS_N_PARTS];
    if (!allowed(self, "fmi2SerializedFMUstateSize", NS_ANY) || !serializable(self, "fmi2SerializedFMUstateSize") ||
        FMUstate == NULL || size == NULL)
        return fmi2Error;
    return part_sizes(self, (const ns_state *)FMUstate, sizes, size);
}

NS_FMI2_API fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    ns_instance *self = (ns_instance *)c;
    const ns_state *state = (const ns_state *)FMUstate;
    size_t sizes[NS_N_PARTS], total, at;
    int64_t i;
    fmi2Status status;
    if (!allowed(self, "fmi2SerializeFMUstate", NS_ANY) || !serializable(self, "fmi2SerializeFMUstate") ||
        state == NULL || serializedState == NULL)
        return fmi2Error;
    status = part_sizes(self, state, sizes, &total);
    if (status != fmi2OK) return status;
    if (size < total) {
        say(self, fmi2Error, "fmi2SerializeFMUstate: %lu bytes given, the state takes %lu", (unsigned long)size,
            (unsigned long)total);
        return fmi2Error;
    }
    memcpy(serializedState, NS_STATE_MAGIC, sizeof NS_STATE_MAGIC);
    memcpy(serializedState + sizeof NS_STATE_MAGIC, &state->own, sizeof(ns_saved));
    at = sizeof NS_STATE_MAGIC + sizeof(ns_saved);
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        uint64_t n = (uint64_t)sizes[i];
        memcpy(serializedState + at, &n, sizeof n);
        at += sizeof n;
        status = part->serialize(part->component, state->parts[i], serializedState + at, sizes[i]);
        if (status > fmi2Warning) {
            say(self, status, "element '%s': fmi2SerializeFMUstate returned status %d", part->config->name,
                (int)status);
            return status;
        }
        at += sizes[i];
    }
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    ns_instance *self = (ns_instance *)c;
    ns_state *state;
    size_t at = sizeof NS_STATE_MAGIC + sizeof(ns_saved);
    int64_t i;
    if (!allowed(self, "fmi2DeSerializeFMUstate", NS_ANY) || !serializable(self, "fmi2DeSerializeFMUstate") ||
        serializedState == NULL || FMUstate == NULL)
        return fmi2Error;
    if (size < at || memcmp(serializedState, NS_STATE_MAGIC, sizeof NS_STATE_MAGIC) != 0) {
        say(self, fmi2Error, "fmi2DeSerializeFMUstate: the %lu bytes are no state of an nnfmu system FMU",
            (unsigned long)size);
        return fmi2Error;
    }
    state = (ns_state *)calloc(1, sizeof(ns_state));
    if (state == NULL) return fmi2Error;
    memcpy(&state->own, serializedState + sizeof NS_STATE_MAGIC, sizeof(ns_saved));
    for (i = 0; i < NS_N_PARTS; i++) {
        ns_part *part = &self->parts[i];
        uint64_t n = 0;
        fmi2Status status = fmi2Error;
        if (size - at >= sizeof n) {
            memcpy(&n, serializedState + at, sizeof n);
            at += sizeof n;
            if (n <= size - at) status = part->deserialize(part->component, serializedState + at, (size_t)n,
                                                           &state->parts[i]);
            at += (size_t)n;
        }
        if (status > fmi2Warning) {
            say(self, fmi2Error, "fmi2DeSerializeFMUstate: element '%s' refused its part of the state",
                part->config->name);
            fmi2FreeFMUstate(c, (fmi2FMUstate *)&state);
            return fmi2Error;
        }
    }
    if (at != size || state->own.mode < NS_INSTANTIATED || state->own.mode > NS_FAILED) {
        say(self, fmi2Error, "fmi2DeSerializeFMUstate: the %lu bytes are no state of this system FMU",
            (unsigned long)size);
        fmi2FreeFMUstate(c, (fmi2FMUstate *)&state);
        return fmi2Error;
    }
    if (*FMUstate != NULL) fmi2FreeFMUstate(c, FMUstate);
    *FMUstate = state;
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref;
    (void)nUnknown;
    (void)vKnown_ref;
    (void)nKnown;
    (void)dvKnown;
    (void)dvUnknown;
    return unsupported(c, "fmi2GetDirectionalDerivative");
}

NS_FMI2_API fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr;
    (void)nvr;
    (void)order;
    (void)value;
    return unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder is 0)");
}

NS_FMI2_API fmi2Status fmi2CancelStep(fmi2Component c) { return unsupported(c, "fmi2CancelStep (doStep completes at once)"); }

NS_FMI2_API fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetStatus (doStep completes at once)");
}

NS_FMI2_API fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    ns_instance *self = (ns_instance *)c;
    if (!allowed(self, "fmi2GetRealStatus", NS_ANY) || value == NULL) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return unsupported(c, "fmi2GetRealStatus (except LastSuccessfulTime)");
    *value = self->time;
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetIntegerStatus");
}

NS_FMI2_API fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    ns_instance *self = (ns_instance *)c;
    if (!allowed(self, "fmi2GetBooleanStatus", NS_ANY) || value == NULL) return fmi2Error;
    if (s != fmi2Terminated) return unsupported(c, "fmi2GetBooleanStatus for a kind other than Terminated");
    *value = fmi2False;
    return fmi2OK;
}

NS_FMI2_API fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s;
    (void)value;
    return unsupported(c, "fmi2GetStringStatus");
}
