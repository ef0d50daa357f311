/* fmi2Functions.c: the FMI 2.0 co-simulation interface of an nnfmu FMU, a thin layer over nn_fmu.c.
 *
 * Each function checks its instance, the current mode and its array arguments, then calls the core; the worst
 * status met becomes the return value.
 */
#include "fmi2Functions.h"
#include "nn_fmu.h"

#define READABLE (NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED | NN_FAILED)
#define SETTABLE (NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING)
#define STATEFUL (NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED)
#define RESTORABLE (STATEFUL | NN_FAILED) /* FMI allows rolling back to a saved state after an error */

static void log_fmi2(const void *instance, NNStatus status, const char *category, const char *message) {
    const NNInstance *self = (const NNInstance *)instance;
    fmi2CallbackLogger logger = (fmi2CallbackLogger)self->logger;
    /* The message goes through "%s" so that a '%' in a port name is never read as a format. */
    logger((fmi2ComponentEnvironment)self->environment, self->name, (fmi2Status)status, category, "%s", message);
}

/* The instance behind `c` if `function` may be called in its current mode, else NULL (and the reason logged). */
static NNInstance *checked(fmi2Component c, const char *function, unsigned allowed) {
    NNInstance *instance = (NNInstance *)c;
    if (!instance || !nn_allowed(instance, function, allowed)) return NULL;
    return instance;
}

/* Logs that `function` is not supported and returns fmi2Error. The refused call passes its own arguments after
 * `function` only so that none of them is left unused; they are never read. */
static fmi2Status unsupported(fmi2Component c, const char *function, ...) {
    NNInstance *instance = (NNInstance *)c;
    if (instance) nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s is not supported by this FMU", function);
    return fmi2Error;
}

/* For variable types the FMU does not have: a request for no variables succeeds, any other is refused (the
 * arguments after `function` as in `unsupported`). */
static fmi2Status unless_empty(fmi2Component c, size_t n, const char *function, ...) {
    return n == 0 ? fmi2OK : unsupported(c, function);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }

const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    NNInstance *instance = checked(c, "fmi2SetDebugLogging", NN_ANY_MODE);
    if (!instance) return fmi2Error;
    return (fmi2Status)nn_set_debug_logging(instance, loggingOn != fmi2False, nCategories, categories);
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    NNInstance *instance;
    (void)fmuResourceLocation;
    (void)visible;
    if (!functions) return NULL;
    instance = nn_instantiate(instanceName, fmuGUID, log_fmi2, (NNCallback)functions->logger,
                              functions->componentEnvironment, loggingOn != fmi2False);
    if (instance && fmuType != fmi2CoSimulation) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "fmi2Instantiate: %s supports co-simulation only",
               NN_MODEL_IDENTIFIER);
        nn_free(instance);
        return NULL;
    }
    return instance;
}

void fmi2FreeInstance(fmi2Component c) { nn_free((NNInstance *)c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    NNInstance *instance = checked(c, "fmi2SetupExperiment", NN_INSTANTIATED);
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!instance) return fmi2Error;
    return (fmi2Status)nn_setup_experiment(instance, startTime);
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    NNInstance *instance = checked(c, "fmi2EnterInitializationMode", NN_INSTANTIATED);
    if (!instance) return fmi2Error;
    return (fmi2Status)nn_enter_initialization(instance, instance->data.start_time);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    NNInstance *instance = checked(c, "fmi2ExitInitializationMode", NN_INITIALIZATION);
    if (!instance) return fmi2Error;
    return (fmi2Status)nn_exit_initialization(instance);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    NNInstance *instance = checked(c, "fmi2Terminate", NN_STEPPING | NN_FAILED);
    if (!instance) return fmi2Error;
    instance->mode = NN_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    NNInstance *instance = checked(c, "fmi2Reset", NN_ANY_MODE);
    if (!instance) return fmi2Error;
    nn_reset(instance);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    NNInstance *instance = checked(c, "fmi2GetReal", READABLE);
    if (!instance || !nn_check_array(instance, "fmi2GetReal", vr, nvr, "vr") ||
        !nn_check_array(instance, "fmi2GetReal", value, nvr, "value")) return fmi2Error;
    return (fmi2Status)nn_get_reals(instance, vr, nvr, value);
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    return unless_empty(c, nvr, "fmi2GetInteger (the FMU has no Integer variables)", vr, value);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    NNInstance *instance = checked(c, "fmi2GetBoolean", READABLE);
    size_t i;
    if (!instance || !nn_check_array(instance, "fmi2GetBoolean", vr, nvr, "vr") ||
        !nn_check_array(instance, "fmi2GetBoolean", value, nvr, "value")) return fmi2Error;
    for (i = 0; i < nvr; i++) {
        int flag = 0;
        NNStatus status = nn_get_boolean(instance, vr[i], &flag);
        if (status != NN_OK) return (fmi2Status)status;
        value[i] = flag ? fmi2True : fmi2False;
    }
    return fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    return unless_empty(c, nvr, "fmi2GetString (the FMU has no String variables)", vr, value);
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    NNInstance *instance = checked(c, "fmi2SetReal", SETTABLE);
    if (!instance || !nn_check_array(instance, "fmi2SetReal", vr, nvr, "vr") ||
        !nn_check_array(instance, "fmi2SetReal", value, nvr, "value")) return fmi2Error;
    return (fmi2Status)nn_set_reals(instance, vr, nvr, value);
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    return unless_empty(c, nvr, "fmi2SetInteger (the FMU has no Integer variables)", vr, value);
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    return unless_empty(c, nvr, "fmi2SetBoolean (the FMU has no Boolean inputs or parameters)", vr, value);
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    return unless_empty(c, nvr, "fmi2SetString (the FMU has no String variables)", vr, value);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    NNInstance *instance = checked(c, "fmi2GetFMUstate", STATEFUL);
    if (!instance || !nn_check_array(instance, "fmi2GetFMUstate", FMUstate, 1, "FMUstate")) return fmi2Error;
    return (fmi2Status)nn_state_save(instance, FMUstate);
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    NNInstance *instance = checked(c, "fmi2SetFMUstate", RESTORABLE);
    if (!instance || !nn_check_array(instance, "fmi2SetFMUstate", FMUstate, 1, "FMUstate")) return fmi2Error;
    return (fmi2Status)nn_state_restore(instance, (const NNModelData *)FMUstate);
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    NNInstance *instance = checked(c, "fmi2FreeFMUstate", NN_ANY_MODE);
    if (!instance) return fmi2Error;
    nn_state_free(FMUstate);
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    NNInstance *instance = checked(c, "fmi2SerializedFMUstateSize", NN_ANY_MODE);
    if (!instance || !nn_check_array(instance, "fmi2SerializedFMUstateSize", size, 1, "size")) return fmi2Error;
    (void)FMUstate;
    *size = nn_serialized_size();
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    NNInstance *instance = checked(c, "fmi2SerializeFMUstate", NN_ANY_MODE);
    if (!instance || !nn_check_array(instance, "fmi2SerializeFMUstate", FMUstate, 1, "FMUstate") ||
        !nn_check_array(instance, "fmi2SerializeFMUstate", serializedState, size, "serializedState")) return fmi2Error;
    return (fmi2Status)nn_serialize(instance, (const NNModelData *)FMUstate, (unsigned char *)serializedState, size);
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    NNInstance *instance = checked(c, "fmi2DeSerializeFMUstate", NN_ANY_MODE);
    if (!instance || !nn_check_array(instance, "fmi2DeSerializeFMUstate", serializedState, size, "serializedState") ||
        !nn_check_array(instance, "fmi2DeSerializeFMUstate", FMUstate, 1, "FMUstate")) return fmi2Error;
    return (fmi2Status)nn_deserialize(instance, (const unsigned char *)serializedState, size, FMUstate);
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    const char *function = "fmi2GetDirectionalDerivative";
    NNInstance *instance = checked(c, function, READABLE);
    if (!instance || !nn_check_array(instance, function, vUnknown_ref, nUnknown, "vUnknown_ref") ||
        !nn_check_array(instance, function, vKnown_ref, nKnown, "vKnown_ref") ||
        !nn_check_array(instance, function, dvKnown, nKnown, "dvKnown") ||
        !nn_check_array(instance, function, dvUnknown, nUnknown, "dvUnknown")) return fmi2Error;
    return (fmi2Status)nn_directional_derivative(instance, function, vUnknown_ref, nUnknown, vKnown_ref, nKnown,
                                                 dvKnown, dvUnknown);
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    NNInstance *instance = checked(c, "fmi2SetRealInputDerivatives", SETTABLE);
    if (!instance || !nn_check_array(instance, "fmi2SetRealInputDerivatives", vr, nvr, "vr") ||
        !nn_check_array(instance, "fmi2SetRealInputDerivatives", order, nvr, "order") ||
        !nn_check_array(instance, "fmi2SetRealInputDerivatives", value, nvr, "value")) return fmi2Error;
    return (fmi2Status)nn_set_input_slopes(instance, vr, nvr, order, value);
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    return unsupported(c, "fmi2GetRealOutputDerivatives (maxOutputDerivativeOrder is 0)", vr, nvr, order, value);
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    NNInstance *instance = checked(c, "fmi2DoStep", NN_STEPPING);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!instance) return fmi2Error;
    return (fmi2Status)nn_do_step(instance, currentCommunicationPoint, communicationStepSize);
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return unsupported(c, "fmi2CancelStep (doStep always completes synchronously)");
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    return unsupported(c, "fmi2GetStatus (doStep always completes synchronously)", s, value);
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    NNInstance *instance = checked(c, "fmi2GetRealStatus", READABLE);
    if (!instance || !nn_check_array(instance, "fmi2GetRealStatus", value, 1, "value")) return fmi2Error;
    if (s != fmi2LastSuccessfulTime) return unsupported(c, "fmi2GetRealStatus (except LastSuccessfulTime)");
    *value = instance->data.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    return unsupported(c, "fmi2GetIntegerStatus", s, value);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    NNInstance *instance = checked(c, "fmi2GetBooleanStatus", READABLE);
    if (!instance || !nn_check_array(instance, "fmi2GetBooleanStatus", value, 1, "value")) return fmi2Error;
    if (s != fmi2Terminated) return unsupported(c, "fmi2GetBooleanStatus for a kind other than Terminated");
    *value = fmi2False; /* the FMU never asks to end the simulation */
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    return unsupported(c, "fmi2GetStringStatus", s, value);
}
