/* system_fmu3.c: the FMI 3.0 co-simulation interface of a system FMU (`nnfmu system build --fmi 3`): the FMI 2
 * functions of system_fmu.c, compiled in here as static functions, under FMI 3 calls. FMI 3 co-simulation has no
 * input derivatives, so the drive is held over each step; the independent variable `time` has the value reference
 * after the parameters (NS_VR_END).
 */
#define NS_FMI3_GLUE
#include "system_fmu.c"

#include "fmi3Functions.h"

/* The importer's FMI 3 logger behind the FMI 2 logger the system FMU's core calls. */
typedef struct {
    fmi3InstanceEnvironment environment;
    fmi3LogMessageCallback log;
} ns_logger3;

static void log_adapter(fmi2ComponentEnvironment environment, fmi2String name, fmi2Status status,
                        fmi2String category, fmi2String message, ...) {
    const ns_logger3 *logger = (const ns_logger3 *)environment;
    char text[NS_MESSAGE];
    va_list args;
    (void)name;
    if (logger == NULL || logger->log == NULL || message == NULL) return;
    va_start(args, message);
    vsnprintf(text, sizeof text, message, args);
    va_end(args);
    logger->log(logger->environment, (fmi3Status)status, category, text);
}

/* `path` as a file: URI (bytes outside the unreserved set and '/' percent-encoded), in a new string. */
static char *file_uri(const char *path) {
    static const char hex[] = "0123456789ABCDEF";
    size_t n = strlen(path);
    char *uri = (char *)malloc(3 * n + 8), *out;
    const unsigned char *p;
    if (uri == NULL) return NULL;
    strcpy(uri, "file://");
    out = uri + 7;
    for (p = (const unsigned char *)path; *p; p++) {
        if ((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') || strchr("-._~/", *p)) {
            *out++ = (char)*p;
        } else {
            *out++ = '%';
            *out++ = hex[*p >> 4];
            *out++ = hex[*p & 15];
        }
    }
    *out = 0;
    return uri;
}

/* Logs that `function` is refused and returns fmi3Error; the arguments after `function` are never read (they are
 * passed only so that none is left unused). */
static fmi3Status refused3(fmi3Instance instance, const char *function, ...) {
    ns_instance *self = (ns_instance *)instance;
    if (self != NULL) say(self, fmi2Error, "%s is not supported by this system FMU", function);
    return fmi3Error;
}

static fmi3Status empty3(fmi3Instance instance, size_t n, const char *function, ...) {
    return n == 0 ? fmi3OK : refused3(instance, function);
}

static int scalars(fmi3Instance instance, const char *function, size_t nvr, size_t nValues) {
    if (nvr == nValues) return 1;
    say((ns_instance *)instance, fmi2Error, "%s: nValues = %lu but %lu scalar variables were given", function,
        (unsigned long)nValues, (unsigned long)nvr);
    return 0;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return (fmi3Status)fmi2SetDebugLogging(instance, loggingOn ? fmi2True : fmi2False, nCategories, categories);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    ns_logger3 *logger = (ns_logger3 *)calloc(1, sizeof(ns_logger3));
    fmi2CallbackFunctions callbacks = {log_adapter, calloc, free, NULL, NULL};
    char *uri;
    fmi2Component c;
    (void)visible;
    (void)eventModeUsed;
    (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables;
    (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (logger == NULL) return NULL;
    logger->environment = instanceEnvironment;
    logger->log = logMessage;
    callbacks.componentEnvironment = logger;
    if (resourcePath == NULL) {
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "no resource path given");
        free(logger);
        return NULL;
    }
    uri = file_uri(resourcePath);
    c = uri ? fmi2Instantiate(instanceName, fmi2CoSimulation, instantiationToken, uri, &callbacks, fmi2False,
                              loggingOn ? fmi2True : fmi2False)
            : NULL;
    free(uri);
    if (c == NULL) free(logger);
    return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName;
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError", "co-simulation only");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    ns_instance *self = (ns_instance *)instance;
    void *logger = self ? self->outer.componentEnvironment : NULL;
    fmi2FreeInstance(instance);
    free(logger);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    fmi2Status status = fmi2SetupExperiment(instance, toleranceDefined ? fmi2True : fmi2False, tolerance, startTime,
                                            stopTimeDefined ? fmi2True : fmi2False, stopTime);
    if (status > fmi2Warning) return (fmi3Status)status;
    return (fmi3Status)fmi2EnterInitializationMode(instance);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return (fmi3Status)fmi2ExitInitializationMode(instance);
}

fmi3Status fmi3Terminate(fmi3Instance instance) { return (fmi3Status)fmi2Terminate(instance); }

fmi3Status fmi3Reset(fmi3Instance instance) { return (fmi3Status)fmi2Reset(instance); }

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          fmi3Float64 values[], size_t nValues) {
    size_t i;
    if (instance == NULL || !scalars(instance, "fmi3GetFloat64", nValueReferences, nValues)) return fmi3Error;
    for (i = 0; i < nValueReferences; i++) {
        fmi2Status status;
        if (valueReferences[i] == NS_VR_END) {
            values[i] = ((ns_instance *)instance)->time;
            continue;
        }
        status = fmi2GetReal(instance, &valueReferences[i], 1, &values[i]);
        if (status > fmi2Warning) return (fmi3Status)status;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                          const fmi3Float64 values[], size_t nValues) {
    if (instance == NULL || !scalars(instance, "fmi3SetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)fmi2SetReal(instance, valueReferences, nValueReferences, values);
}

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2GetFMUstate(instance, FMUState);
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    return (fmi3Status)fmi2SetFMUstate(instance, FMUState);
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2FreeFMUstate(instance, FMUState);
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    return (fmi3Status)fmi2SerializedFMUstateSize(instance, FMUState, size);
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState, fmi3Byte serializedState[],
                                 size_t size) {
    return (fmi3Status)fmi2SerializeFMUstate(instance, FMUState, (fmi2Byte *)serializedState, size);
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    return (fmi3Status)fmi2DeSerializeFMUstate(instance, (const fmi2Byte *)serializedState, size, FMUState);
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    return refused3(instance, "fmi3GetDirectionalDerivative", unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                    sensitivity, nSensitivity);
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn,
                      fmi3Float64 *lastSuccessfulTime) {
    fmi2Status status;
    if (instance == NULL || !eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return fmi3Error;
    status = fmi2DoStep(instance, currentCommunicationPoint, communicationStepSize,
                        noSetFMUStatePriorToCurrentPoint ? fmi2True : fmi2False);
    *eventHandlingNeeded = fmi3False;
    *terminateSimulation = fmi3False;
    *earlyReturn = fmi3False;
    *lastSuccessfulTime = ((ns_instance *)instance)->time;
    return (fmi3Status)status;
}

/* Variable types this FMU does not have: an empty request succeeds, any other is refused. */
#define NS_NO_VARIABLES_OF_TYPE(function, type, qualifier)                                                        \
    fmi3Status function(fmi3Instance instance, const fmi3ValueReference valueReferences[],                         \
                        size_t nValueReferences, qualifier type values[], size_t nValues) {                        \
        return empty3(instance, nValueReferences, #function " (no variables of this type)", valueReferences, \
                            values, nValues);                                                                      \
    }

NS_NO_VARIABLES_OF_TYPE(fmi3GetFloat32, fmi3Float32, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetInt8, fmi3Int8, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetUInt8, fmi3UInt8, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetInt16, fmi3Int16, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetUInt16, fmi3UInt16, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetInt32, fmi3Int32, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetUInt32, fmi3UInt32, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetInt64, fmi3Int64, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetUInt64, fmi3UInt64, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetString, fmi3String, )
NS_NO_VARIABLES_OF_TYPE(fmi3GetBoolean, fmi3Boolean, )
NS_NO_VARIABLES_OF_TYPE(fmi3SetFloat32, fmi3Float32, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetInt8, fmi3Int8, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetUInt8, fmi3UInt8, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetInt16, fmi3Int16, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetUInt16, fmi3UInt16, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetInt32, fmi3Int32, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetUInt32, fmi3UInt32, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetInt64, fmi3Int64, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetUInt64, fmi3UInt64, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetString, fmi3String, const)
NS_NO_VARIABLES_OF_TYPE(fmi3SetBoolean, fmi3Boolean, const)

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return refused3(instance, "fmi3EnterEventMode (hasEventMode is false)");
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         size_t valueSizes[], fmi3Binary values[], size_t nValues) {
    return empty3(instance, nValueReferences, "fmi3GetBinary (no Binary variables)",
                        valueReferences, valueSizes, values, nValues);
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                         const size_t valueSizes[], const fmi3Binary values[], size_t nValues) {
    return empty3(instance, nValueReferences, "fmi3SetBinary (no Binary variables)",
                        valueReferences, valueSizes, values, nValues);
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        fmi3Clock values[]) {
    return empty3(instance, nValueReferences, "fmi3GetClock (no clocks)", valueReferences, values);
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences,
                        const fmi3Clock values[]) {
    return empty3(instance, nValueReferences, "fmi3SetClock (no clocks)", valueReferences, values);
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance, fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    return refused3(instance, "fmi3GetNumberOfVariableDependencies (see ModelStructure in modelDescription.xml)",
                       valueReference, nDependencies);
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
    return refused3(instance, "fmi3GetVariableDependencies (see ModelStructure in modelDescription.xml)",
                       dependent, elementIndicesOfDependent, independents, elementIndicesOfIndependents, dependencyKinds, nDependencies);
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
    return refused3(instance, "fmi3GetAdjointDerivative",
                       unknowns, nUnknowns, knowns, nKnowns, seed, nSeed, sensitivity, nSensitivity);
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return refused3(instance, "fmi3EnterConfigurationMode (no structural parameters)");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return refused3(instance, "fmi3ExitConfigurationMode (no structural parameters)");
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    return refused3(instance, "fmi3GetIntervalDecimal (no clocks)",
                       valueReferences, nValueReferences, intervals, qualifiers);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[],
                                   fmi3IntervalQualifier qualifiers[]) {
    return refused3(instance, "fmi3GetIntervalFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions, qualifiers);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    return refused3(instance, "fmi3GetShiftDecimal (no clocks)", valueReferences, nValueReferences, shifts);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]) {
    return refused3(instance, "fmi3GetShiftFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    return refused3(instance, "fmi3SetIntervalDecimal (no clocks)", valueReferences, nValueReferences, intervals);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    return refused3(instance, "fmi3SetIntervalFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    return refused3(instance, "fmi3SetShiftDecimal (no clocks)", valueReferences, nValueReferences, shifts);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    return refused3(instance, "fmi3SetShiftFraction (no clocks)",
                       valueReferences, nValueReferences, counters, resolutions);
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return refused3(instance, "fmi3EvaluateDiscreteStates (hasEventMode is false)");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    return refused3(instance, "fmi3UpdateDiscreteStates (hasEventMode is false)",
                       discreteStatesNeedUpdate, terminateSimulation, nominalsOfContinuousStatesChanged, valuesOfContinuousStatesChanged, nextEventTimeDefined, nextEventTime);
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return refused3(instance, "fmi3EnterStepMode (hasEventMode is false: Step Mode follows initialisation)");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[],
                                    size_t nValues) {
    return refused3(instance, "fmi3GetOutputDerivatives (maxOutputDerivativeOrder is 0)",
                       valueReferences, nValueReferences, orders, values, nValues);
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return refused3(instance, "fmi3EnterContinuousTimeMode (co-simulation only)");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    return refused3(instance, "fmi3CompletedIntegratorStep (co-simulation only)",
                       noSetFMUStatePriorToCurrentPoint, enterEventMode, terminateSimulation);
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    return refused3(instance, "fmi3SetTime (co-simulation only)", time);
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    return refused3(instance, "fmi3SetContinuousStates (co-simulation only)", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    return refused3(instance, "fmi3GetContinuousStateDerivatives (co-simulation only)",
                       derivatives, nContinuousStates);
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    return refused3(instance, "fmi3GetEventIndicators (co-simulation only)", eventIndicators, nEventIndicators);
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    return refused3(instance, "fmi3GetContinuousStates (co-simulation only)", continuousStates, nContinuousStates);
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    return refused3(instance, "fmi3GetNominalsOfContinuousStates (co-simulation only)",
                       nominals, nContinuousStates);
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    return refused3(instance, "fmi3GetNumberOfEventIndicators (co-simulation only)", nEventIndicators);
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    return refused3(instance, "fmi3GetNumberOfContinuousStates (co-simulation only)", nContinuousStates);
}

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    return refused3(instance, "fmi3ActivateModelPartition (co-simulation only)", clockReference, activationTime);
}
