/* fmi3Functions.c: the FMI 3.0 co-simulation interface of an nnfmu FMU, a thin layer over nn_fmu.c.
 *
 * Each function checks its instance, the current mode and its array arguments, then calls the core. The FMU has
 * Float64 and Boolean variables only and no event mode; every other function logs why it is refused.
 */
#include "fmi3Functions.h"
#include "nn_fmu.h"

#define READABLE (NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED | NN_FAILED)
#define SETTABLE (NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING)
#define STATEFUL (NN_INSTANTIATED | NN_INITIALIZATION | NN_STEPPING | NN_TERMINATED)
#define RESTORABLE (STATEFUL | NN_FAILED) /* FMI allows rolling back to a saved state after an error */

static void log_fmi3(const void *instance, NNStatus status, const char *category, const char *message) {
    const NNInstance *self = (const NNInstance *)instance;
    fmi3LogMessageCallback logger = (fmi3LogMessageCallback)self->logger;
    logger((fmi3InstanceEnvironment)self->environment, (fmi3Status)status, category, message);
}

/* The instance behind `c` if `function` may be called in its current mode, else NULL (and the reason logged). */
static NNInstance *checked(fmi3Instance c, const char *function, unsigned allowed) {
    NNInstance *instance = (NNInstance *)c;
    if (!instance || !nn_allowed(instance, function, allowed)) return NULL;
    return instance;
}

/* Logs that `function` is not supported and returns fmi3Error. The refused call passes its own arguments after
 * `function` only so that none of them is left unused; they are never read. */
static fmi3Status unsupported(fmi3Instance c, const char *function, ...) {
    NNInstance *instance = (NNInstance *)c;
    if (instance) nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s is not supported by this FMU", function);
    return fmi3Error;
}

/* For variable types the FMU does not have: a request for no variables succeeds, any other is refused (the
 * arguments after `function` as in `unsupported`). */
static fmi3Status unless_empty(fmi3Instance c, size_t n, const char *function, ...) {
    return n == 0 ? fmi3OK : unsupported(c, function);
}

/* Scalar variables only: one value per value reference. */
static NNInstance *checked_access(fmi3Instance c, const char *function, unsigned allowed,
                                  const fmi3ValueReference vr[], size_t nvr, const void *values, size_t nValues) {
    NNInstance *instance = checked(c, function, allowed);
    if (!instance || !nn_check_array(instance, function, vr, nvr, "valueReferences") ||
        !nn_check_array(instance, function, values, nValues, "values")) return NULL;
    if (nValues != nvr) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "%s: nValues = %lu but %lu scalar variables were given", function,
               (unsigned long)nValues, (unsigned long)nvr);
        return NULL;
    }
    return instance;
}

/* Instantiation for another interface type: logged as refused, no instance (the arguments after `logMessage` as in
 * `unsupported`). */
static fmi3Instance co_simulation_only(fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                       ...) {
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "co-simulation only");
    return NULL;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    NNInstance *self = checked(instance, "fmi3SetDebugLogging", NN_ANY_MODE);
    if (!self) return fmi3Error;
    return (fmi3Status)nn_set_debug_logging(self, loggingOn, nCategories, categories);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    return co_simulation_only(instanceEnvironment, logMessage, instanceName, instantiationToken, resourcePath, visible,
                              loggingOn);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    NNInstance *instance;
    (void)resourcePath;
    (void)visible;
    (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    instance = nn_instantiate(instanceName, instantiationToken, log_fmi3, (NNCallback)logMessage,
                              instanceEnvironment, loggingOn);
    if (instance && (eventModeUsed || nRequiredIntermediateVariables > 0)) {
        nn_log(instance, NN_ERROR, NN_LOG_ERROR, "fmi3InstantiateCoSimulation: %s has no event mode and no "
               "intermediate variables", NN_MODEL_IDENTIFIER);
        nn_free(instance);
        return NULL;
    }
    return instance;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    return co_simulation_only(instanceEnvironment, logMessage, instanceName, instantiationToken, resourcePath, visible,
                              loggingOn, clockUpdate, lockPreemption, unlockPreemption);
}

void fmi3FreeInstance(fmi3Instance instance) { nn_free((NNInstance *)instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    NNInstance *self = checked(instance, "fmi3EnterInitializationMode", NN_INSTANTIATED);
    (void)toleranceDefined;
    (void)tolerance;
    (void)stopTimeDefined;
    (void)stopTime;
    if (!self) return fmi3Error;
    return (fmi3Status)nn_enter_initialization(self, startTime);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    NNInstance *self = checked(instance, "fmi3ExitInitializationMode", NN_INITIALIZATION);
    if (!self) return fmi3Error;
    return (fmi3Status)nn_exit_initialization(self);
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterEventMode (hasEventMode is false)");
}

fmi3Status fmi3Terminate(fmi3Instance instance) {
    NNInstance *self = checked(instance, "fmi3Terminate", NN_STEPPING | NN_FAILED);
    if (!self) return fmi3Error;
    self->mode = NN_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    NNInstance *self = checked(instance, "fmi3Reset", NN_ANY_MODE);
    if (!self) return fmi3Error;
    nn_reset(self);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    NNInstance *self = checked_access(instance, "fmi3GetFloat64", READABLE, valueReferences,
                                      nValueReferences, values, nValues);
    if (!self) return fmi3Error;
    return (fmi3Status)nn_get_reals(self, valueReferences, nValueReferences, values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    NNInstance *self = checked_access(instance, "fmi3SetFloat64", SETTABLE, valueReferences, nValueReferences,
                                      values, nValues);
    if (!self) return fmi3Error;
    return (fmi3Status)nn_set_reals(self, valueReferences, nValueReferences, values);
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues) {
    NNInstance *self = checked_access(instance, "fmi3GetBoolean", READABLE, valueReferences,
                                      nValueReferences, values, nValues);
    size_t i;
    if (!self) return fmi3Error;
    for (i = 0; i < nValueReferences; i++) {
        int flag = 0;
        NNStatus status = nn_get_boolean(self, valueReferences[i], &flag);
        if (status != NN_OK) return (fmi3Status)status;
        values[i] = flag ? fmi3True : fmi3False;
    }
    return fmi3OK;
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues) {
    return unless_empty(instance, nValueReferences, "fmi3SetBoolean (no Boolean inputs or parameters)",
                        valueReferences, values, nValues);
}

/* Variable types this FMU does not have: an empty request succeeds, any other is refused. */
#define NN_NO_VARIABLES_OF_TYPE(function, type, qualifier)                                                        \
    fmi3Status function(fmi3Instance instance, const fmi3ValueReference valueReferences[],                         \
                        size_t nValueReferences, qualifier type values[], size_t nValues) {                        \
        return unless_empty(instance, nValueReferences, #function " (no variables of this type)", valueReferences, \
                            values, nValues);                                                                      \
    }

NN_NO_VARIABLES_OF_TYPE(fmi3GetFloat32, fmi3Float32, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetInt8, fmi3Int8, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetUInt8, fmi3UInt8, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetInt16, fmi3Int16, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetUInt16, fmi3UInt16, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetInt32, fmi3Int32, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetUInt32, fmi3UInt32, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetInt64, fmi3Int64, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetUInt64, fmi3UInt64, )
NN_NO_VARIABLES_OF_TYPE(fmi3GetString, fmi3String, )
NN_NO_VARIABLES_OF_TYPE(fmi3SetFloat32, fmi3Float32, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetInt8, fmi3Int8, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetUInt8, fmi3UInt8, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetInt16, fmi3Int16, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetUInt16, fmi3UInt16, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetInt32, fmi3Int32, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetUInt32, fmi3UInt32, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetInt64, fmi3Int64, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetUInt64, fmi3UInt64, const)
NN_NO_VARIABLES_OF_TYPE(fmi3SetString, fmi3String, const)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    return unless_empty(instance, nValueReferences, "fmi3GetBinary (no Binary variables)",
                        valueReferences, valueSizes, values, nValues);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    return unless_empty(instance, nValueReferences, "fmi3SetBinary (no Binary variables)",
                        valueReferences, valueSizes, values, nValues);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    return unless_empty(instance, nValueReferences, "fmi3GetClock (no clocks)", valueReferences, values);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    return unless_empty(instance, nValueReferences, "fmi3SetClock (no clocks)", valueReferences, values);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    return unsupported(instance, "fmi3GetNumberOfVariableDependencies (see ModelStructure in modelDescription.xml)",
                       valueReference, nDependencies);
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    return unsupported(instance, "fmi3GetVariableDependencies (see ModelStructure in modelDescription.xml)",
                       dependent, elementIndicesOfDependent, independents, elementIndicesOfIndependents, dependencyKinds, nDependencies);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    NNInstance *self = checked(instance, "fmi3GetFMUState", STATEFUL);
    if (!self || !nn_check_array(self, "fmi3GetFMUState", FMUState, 1, "FMUState")) return fmi3Error;
    return (fmi3Status)nn_state_save(self, FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    NNInstance *self = checked(instance, "fmi3SetFMUState", RESTORABLE);
    if (!self || !nn_check_array(self, "fmi3SetFMUState", FMUState, 1, "FMUState")) return fmi3Error;
    return (fmi3Status)nn_state_restore(self, (const NNModelData *)FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    NNInstance *self = checked(instance, "fmi3FreeFMUState", NN_ANY_MODE);
    if (!self) return fmi3Error;
    nn_state_free(FMUState);
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    NNInstance *self = checked(instance, "fmi3SerializedFMUStateSize", NN_ANY_MODE);
    (void)FMUState;
    if (!self || !nn_check_array(self, "fmi3SerializedFMUStateSize", size, 1, "size")) return fmi3Error;
    *size = nn_serialized_size();
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    NNInstance *self = checked(instance, "fmi3SerializeFMUState", NN_ANY_MODE);
    if (!self || !nn_check_array(self, "fmi3SerializeFMUState", FMUState, 1, "FMUState") ||
        !nn_check_array(self, "fmi3SerializeFMUState", serializedState, size, "serializedState")) return fmi3Error;
    return (fmi3Status)nn_serialize(self, (const NNModelData *)FMUState, serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    NNInstance *self = checked(instance, "fmi3DeserializeFMUState", NN_ANY_MODE);
    if (!self || !nn_check_array(self, "fmi3DeserializeFMUState", serializedState, size, "serializedState") ||
        !nn_check_array(self, "fmi3DeserializeFMUState", FMUState, 1, "FMUState")) return fmi3Error;
    return (fmi3Status)nn_deserialize(self, serializedState, size, FMUState);
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    const char *function = "fmi3GetDirectionalDerivative";
    NNInstance *self = checked(instance, function, READABLE);
    if (!self || !nn_check_array(self, function, unknowns, nUnknowns, "unknowns") ||
        !nn_check_array(self, function, knowns, nKnowns, "knowns") ||
        !nn_check_array(self, function, seed, nSeed, "seed") ||
        !nn_check_array(self, function, sensitivity, nSensitivity, "sensitivity")) return fmi3Error;
    if (nSeed != nKnowns || nSensitivity != nUnknowns) { /* scalar variables only: one value per reference */
        nn_log(self, NN_ERROR, NN_LOG_ERROR, "%s: nSeed = %lu and nSensitivity = %lu must equal nKnowns = %lu and "
               "nUnknowns = %lu (all variables are scalars)", function, (unsigned long)nSeed,
               (unsigned long)nSensitivity, (unsigned long)nKnowns, (unsigned long)nUnknowns);
        return fmi3Error;
    }
    return (fmi3Status)nn_directional_derivative(self, function, unknowns, nUnknowns, knowns, nKnowns, seed,
                                                 sensitivity);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    return unsupported(instance, "fmi3GetAdjointDerivative",
                       unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, nSensitivity);
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterConfigurationMode (no structural parameters)");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3ExitConfigurationMode (no structural parameters)");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    return unsupported(instance, "fmi3GetIntervalDecimal (no clocks)",
                       valueReferences, nValueReferences, intervals, qualifiers);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    return unsupported(instance, "fmi3GetIntervalFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions, qualifiers);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    return unsupported(instance, "fmi3GetShiftDecimal (no clocks)", valueReferences, nValueReferences, shifts);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    return unsupported(instance, "fmi3GetShiftFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    return unsupported(instance, "fmi3SetIntervalDecimal (no clocks)", valueReferences, nValueReferences, intervals);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    return unsupported(instance, "fmi3SetIntervalFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    return unsupported(instance, "fmi3SetShiftDecimal (no clocks)", valueReferences, nValueReferences, shifts);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    return unsupported(instance, "fmi3SetShiftFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return unsupported(instance, "fmi3EvaluateDiscreteStates (hasEventMode is false)");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    return unsupported(instance, "fmi3UpdateDiscreteStates (hasEventMode is false)",
                       discreteStatesNeedUpdate, terminateSimulation, nominalsOfContinuousStatesChanged, valuesOfContinuousStatesChanged, nextEventTimeDefined, nextEventTime);
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterStepMode (hasEventMode is false: Step Mode follows initialisation)");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    return unsupported(instance, "fmi3GetOutputDerivatives (maxOutputDerivativeOrder is 0)",
                       valueReferences, nValueReferences, orders, values, nValues);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    NNInstance *self = checked(instance, "fmi3DoStep", NN_STEPPING);
    fmi3Status status;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!self || !nn_check_array(self, "fmi3DoStep", eventHandlingNeeded, 1, "eventHandlingNeeded") ||
        !nn_check_array(self, "fmi3DoStep", terminateSimulation, 1, "terminateSimulation") ||
        !nn_check_array(self, "fmi3DoStep", earlyReturn, 1, "earlyReturn") ||
        !nn_check_array(self, "fmi3DoStep", lastSuccessfulTime, 1, "lastSuccessfulTime")) return fmi3Error;
    status = (fmi3Status)nn_do_step(self, currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = self->data.time;
    return status;
}

/* Model Exchange and Scheduled Execution functions: this FMU is co-simulation only. */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return unsupported(instance, "fmi3EnterContinuousTimeMode (co-simulation only)");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    return unsupported(instance, "fmi3CompletedIntegratorStep (co-simulation only)",
                       noSetFMUStatePriorToCurrentPoint, enterEventMode, terminateSimulation);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    return unsupported(instance, "fmi3SetTime (co-simulation only)", time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return unsupported(instance, "fmi3SetContinuousStates (co-simulation only)", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    return unsupported(instance, "fmi3GetContinuousStateDerivatives (co-simulation only)",
                       derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    return unsupported(instance, "fmi3GetEventIndicators (co-simulation only)", eventIndicators, nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    return unsupported(instance, "fmi3GetContinuousStates (co-simulation only)", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    return unsupported(instance, "fmi3GetNominalsOfContinuousStates (co-simulation only)",
                       nominals, nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    return unsupported(instance, "fmi3GetNumberOfEventIndicators (co-simulation only)", nEventIndicators);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    return unsupported(instance, "fmi3GetNumberOfContinuousStates (co-simulation only)", nContinuousStates);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    return unsupported(instance, "fmi3ActivateModelPartition (co-simulation only)", clockReference, activationTime);
}
