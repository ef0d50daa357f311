/* system_driver.c's cycle through the FMI 3 interface of a system FMU: instantiate from the unpacked FMU's
 * resources, run `steps` steps of 1 ms (drive held over each step), read every output and the time, terminate,
 * reset, run again, free; a refused instantiation and a refused step; the state saved, serialised, deserialised
 * (and refused cut short), restored and freed half way through each run. Prints the number of unexpected statuses.
 * Usage: system_driver3 LIBRARY TOKEN RESOURCE_PATH N_INPUTS N_OUTPUTS STEPS N_VARIABLES */
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi3Functions.h"

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    (void)category;
    fprintf(stderr, "[%d] %s\n", (int)status, message);
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)

int main(int argc, char **argv) {
    void *lib;
    int n_in, n_out, steps, k, i, run, unexpected = 0;
    fmi3ValueReference vr[64], time_vr;
    fmi3Float64 value[64], now = 0.0;
    fmi3Boolean event, terminate, early;
    fmi3Float64 reached;
    fmi3Instance c;
    if (argc != 8) return 2;
    n_in = atoi(argv[4]);
    n_out = atoi(argv[5]);
    steps = atoi(argv[6]);
    time_vr = (fmi3ValueReference)atoi(argv[7]);
    if (n_in + n_out > 63) return 2;
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        return 2;
    }
    {
        LOAD(fmi3InstantiateCoSimulation);
        LOAD(fmi3FreeInstance);
        LOAD(fmi3EnterInitializationMode);
        LOAD(fmi3ExitInitializationMode);
        LOAD(fmi3SetFloat64);
        LOAD(fmi3GetFloat64);
        LOAD(fmi3DoStep);
        LOAD(fmi3Terminate);
        LOAD(fmi3Reset);
        LOAD(fmi3GetFMUState);
        LOAD(fmi3SetFMUState);
        LOAD(fmi3FreeFMUState);
        LOAD(fmi3SerializedFMUStateSize);
        LOAD(fmi3SerializeFMUState);
        LOAD(fmi3DeserializeFMUState);
        if (fmi3InstantiateCoSimulation("wrong", "{not-the-token}", argv[3], fmi3False, fmi3True, fmi3False, fmi3False,
                                        NULL, 0, NULL, logger, NULL))
            unexpected++;
        c = fmi3InstantiateCoSimulation("system", argv[2], argv[3], fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                                        NULL, logger, NULL);
        if (!c) return 3;
        for (i = 0; i < n_in + n_out; i++) vr[i] = (fmi3ValueReference)i;
        vr[n_in + n_out] = time_vr;
        for (run = 0; run < 2; run++) {
            unexpected += fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK;
            for (i = 0; i < n_in; i++) value[i] = 0.0;
            unexpected += fmi3SetFloat64(c, vr, (size_t)n_in, value, (size_t)n_in) != fmi3OK;
            unexpected += fmi3ExitInitializationMode(c) != fmi3OK;
            for (k = 0; k < steps; k++) {
                double t = k * 1e-3;
                if (k == steps / 2) {
                    fmi3FMUState state = NULL, copy = NULL;
                    size_t size = 0;
                    fmi3Byte *bytes;
                    unexpected += fmi3GetFMUState(c, &state) != fmi3OK;
                    unexpected += fmi3SerializedFMUStateSize(c, state, &size) != fmi3OK;
                    bytes = (fmi3Byte *)malloc(size + 1);
                    if (!bytes) return 2;
                    unexpected += fmi3SerializeFMUState(c, state, bytes, size) != fmi3OK;
                    unexpected += fmi3DeserializeFMUState(c, bytes, size - 1, &copy) != fmi3Error;
                    unexpected += fmi3DeserializeFMUState(c, bytes, size, &copy) != fmi3OK;
                    unexpected += fmi3SetFMUState(c, copy) != fmi3OK;
                    unexpected += fmi3FreeFMUState(c, &copy) != fmi3OK;
                    unexpected += fmi3FreeFMUState(c, &state) != fmi3OK;
                    free(bytes);
                }
                for (i = 0; i < n_in; i++) value[i] = 0.01 * sin(2 * 3.14159 * 3 * t);
                unexpected += fmi3SetFloat64(c, vr, (size_t)n_in, value, (size_t)n_in) != fmi3OK;
                unexpected += fmi3DoStep(c, t, 1e-3, fmi3True, &event, &terminate, &early, &reached) != fmi3OK;
                unexpected += fmi3GetFloat64(c, vr + n_in, (size_t)n_out + 1, value + n_in, (size_t)n_out + 1) != fmi3OK;
                for (i = 0; i < n_out; i++) unexpected += !isfinite(value[n_in + i]);
                now = value[n_in + n_out];
                unexpected += fabs(now - (t + 1e-3)) > 1e-12;
            }
            unexpected += fmi3DoStep(c, now, 0.7e-3, fmi3True, &event, &terminate, &early, &reached) != fmi3Error;
            unexpected += fmi3Terminate(c) != fmi3OK;
            unexpected += fmi3Reset(c) != fmi3OK;
        }
        fmi3FreeInstance(c);
    }
    dlclose(lib);
    fprintf(stderr, "%d unexpected statuses\n", unexpected);
    return unexpected != 0;
}
