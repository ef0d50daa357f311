/* A small FMI 2 master for the system FMU under the sanitizers: instantiate from the unpacked FMU's resources, run
 * `steps` steps of 1 ms with the drive as inputs and their slopes, read every output, terminate, reset, run again,
 * free; also a refused instantiation and a refused step; half way through each run the state is saved, serialised,
 * deserialised, restored and freed. Prints the number of unexpected statuses to stderr.
 * Usage: system_driver LIBRARY GUID RESOURCE_URI N_INPUTS N_OUTPUTS STEPS */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)category;
    fprintf(stderr, "[%s %d] %s\n", name, (int)status, message);
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)

int main(int argc, char **argv) {
    void *lib;
    int n_in, n_out, steps, k, i, run, unexpected = 0;
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference vr[64];
    fmi2Integer order[64];
    fmi2Real value[64], slope[64];
    fmi2Component c;
    if (argc != 7) return 2;
    n_in = atoi(argv[4]);
    n_out = atoi(argv[5]);
    steps = atoi(argv[6]);
    if (n_in + n_out > 64) return 2;
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        return 2;
    }
    {
        LOAD(fmi2Instantiate);
        LOAD(fmi2FreeInstance);
        LOAD(fmi2SetupExperiment);
        LOAD(fmi2EnterInitializationMode);
        LOAD(fmi2ExitInitializationMode);
        LOAD(fmi2SetReal);
        LOAD(fmi2GetReal);
        LOAD(fmi2SetRealInputDerivatives);
        LOAD(fmi2DoStep);
        LOAD(fmi2Terminate);
        LOAD(fmi2Reset);
        LOAD(fmi2GetFMUstate);
        LOAD(fmi2SetFMUstate);
        LOAD(fmi2FreeFMUstate);
        LOAD(fmi2SerializedFMUstateSize);
        LOAD(fmi2SerializeFMUstate);
        LOAD(fmi2DeSerializeFMUstate);
        if (fmi2Instantiate("wrong", fmi2CoSimulation, "{not-the-guid}", argv[3], &callbacks, fmi2False, fmi2True))
            unexpected++;
        c = fmi2Instantiate("system", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False, fmi2False);
        if (!c) return 3;
        for (run = 0; run < 2; run++) {
            unexpected += fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
            unexpected += fmi2EnterInitializationMode(c) != fmi2OK;
            for (i = 0; i < n_in; i++) {
                vr[i] = (fmi2ValueReference)i;
                order[i] = 1;
                value[i] = 0.0;
            }
            unexpected += fmi2SetReal(c, vr, (size_t)n_in, value) != fmi2OK;
            unexpected += fmi2ExitInitializationMode(c) != fmi2OK;
            for (k = 0; k < steps; k++) {
                double t = k * 1e-3;
                if (k == steps / 2) {
                    fmi2FMUstate state = NULL, copy = NULL;
                    size_t size = 0;
                    fmi2Byte *bytes;
                    unexpected += fmi2GetFMUstate(c, &state) != fmi2OK;
                    unexpected += fmi2GetFMUstate(c, &state) != fmi2OK; /* again, into the same state */
                    unexpected += fmi2SerializedFMUstateSize(c, state, &size) != fmi2OK;
                    bytes = (fmi2Byte *)malloc(size + 1);
                    if (!bytes) return 2;
                    unexpected += fmi2SerializeFMUstate(c, state, bytes, size) != fmi2OK;
                    unexpected += fmi2DeSerializeFMUstate(c, bytes, size - 1, &copy) != fmi2Error; /* cut short */
                    unexpected += fmi2DeSerializeFMUstate(c, bytes, size, &copy) != fmi2OK;
                    unexpected += fmi2SetFMUstate(c, copy) != fmi2OK;
                    unexpected += fmi2FreeFMUstate(c, &copy) != fmi2OK;
                    unexpected += fmi2FreeFMUstate(c, &state) != fmi2OK;
                    free(bytes);
                }
                for (i = 0; i < n_in; i++) {
                    value[i] = 0.01 * sin(2 * 3.14159 * 3 * t);
                    slope[i] = 0.01 * 2 * 3.14159 * 3 * cos(2 * 3.14159 * 3 * t);
                }
                unexpected += fmi2SetReal(c, vr, (size_t)n_in, value) != fmi2OK;
                unexpected += fmi2SetRealInputDerivatives(c, vr, (size_t)n_in, order, slope) != fmi2OK;
                unexpected += fmi2DoStep(c, t, 1e-3, fmi2True) != fmi2OK;
                for (i = 0; i < n_out; i++) vr[n_in + i] = (fmi2ValueReference)(n_in + i);
                unexpected += fmi2GetReal(c, vr + n_in, (size_t)n_out, value + n_in) != fmi2OK;
                for (i = 0; i < n_out; i++) unexpected += !isfinite(value[n_in + i]);
            }
            unexpected += fmi2DoStep(c, steps * 1e-3, 0.7e-3, fmi2True) != fmi2Error; /* off the inner grid */
            unexpected += fmi2Terminate(c) != fmi2OK;
            unexpected += fmi2Reset(c) != fmi2OK;
        }
        fmi2FreeInstance(c);
    }
    dlclose(lib);
    fprintf(stderr, "%d unexpected statuses\n", unexpected);
    return unexpected != 0;
}
