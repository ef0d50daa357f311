/* The outer master of bench/cosim.py's compiled engine: steps a system FMU at a fixed step from C, as a compiled
 * tool (Simulink, a C master) would: per step the drive and its slopes, doStep, every output.
 * Usage: system_fmu_driver LIBRARY GUID RESOURCE_URI N_INPUTS N_OUTPUTS STEPS H DRIVE_FILE OUT_FILE
 * DRIVE_FILE: (STEPS + 1) x N_INPUTS doubles (native byte order), OUT_FILE receives (STEPS + 1) x N_OUTPUTS.
 * Prints the seconds of the stepping loop, and of the FMU's whole run from dlopen to the library closed; reading the
 * drive file, touching the output table's pages and writing OUT_FILE are the driver's own work and not timed. */
#define _POSIX_C_SOURCE 199309L
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)category;
    fprintf(stderr, "[%s %d] %s\n", name, (int)status, message);
}

static double seconds(void) {
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
#define CHECK(call)                                                                                                   \
    if ((call) > fmi2Warning) {                                                                                       \
        fprintf(stderr, "failed: %s\n", #call);                                                                       \
        return 3;                                                                                                     \
    }

int main(int argc, char **argv) {
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    double opened, looped, h, *u, *y, *slope;
    long steps, k, i, n_in, n_out;
    fmi2ValueReference *in_vr, *out_vr;
    fmi2Integer *order;
    fmi2Component c;
    FILE *file;
    void *lib;
    if (argc != 10) return 2;
    n_in = atol(argv[4]);
    n_out = atol(argv[5]);
    steps = atol(argv[6]);
    h = atof(argv[7]);
    u = (double *)malloc(sizeof(double) * (size_t)((steps + 1) * n_in + 1));
    y = (double *)malloc(sizeof(double) * (size_t)((steps + 1) * n_out + 1));
    slope = (double *)malloc(sizeof(double) * (size_t)(n_in + 1));
    in_vr = (fmi2ValueReference *)malloc(sizeof(fmi2ValueReference) * (size_t)(n_in + 1));
    out_vr = (fmi2ValueReference *)malloc(sizeof(fmi2ValueReference) * (size_t)(n_out + 1));
    order = (fmi2Integer *)malloc(sizeof(fmi2Integer) * (size_t)(n_in + 1));
    file = fopen(argv[8], "rb");
    if (!u || !y || !slope || !in_vr || !out_vr || !order || !file) return 2;
    if (fread(u, sizeof(double), (size_t)((steps + 1) * n_in), file) != (size_t)((steps + 1) * n_in)) return 2;
    fclose(file);
    for (i = 0; i < n_in; i++) {
        in_vr[i] = (fmi2ValueReference)i;
        order[i] = 1;
    }
    for (i = 0; i < n_out; i++) out_vr[i] = (fmi2ValueReference)(n_in + i);
    memset(y, 0, sizeof(double) * (size_t)((steps + 1) * n_out)); /* the table's pages, before the clock starts */
    opened = seconds();
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
        c = fmi2Instantiate("system", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False, fmi2False);
        if (!c) return 3;
        CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        CHECK(fmi2EnterInitializationMode(c));
        CHECK(fmi2SetReal(c, in_vr, (size_t)n_in, u));
        CHECK(fmi2ExitInitializationMode(c));
        CHECK(fmi2GetReal(c, out_vr, (size_t)n_out, y));
        looped = seconds();
        for (k = 0; k < steps; k++) {
            const double *now = u + k * n_in;
            for (i = 0; i < n_in; i++) slope[i] = (now[n_in + i] - now[i]) / h;
            CHECK(fmi2SetReal(c, in_vr, (size_t)n_in, now));
            CHECK(fmi2SetRealInputDerivatives(c, in_vr, (size_t)n_in, order, slope));
            CHECK(fmi2DoStep(c, (double)k * h, h, fmi2True));
            CHECK(fmi2GetReal(c, out_vr, (size_t)n_out, y + (k + 1) * n_out));
        }
        looped = seconds() - looped;
        CHECK(fmi2Terminate(c));
        fmi2FreeInstance(c);
    }
    dlclose(lib);
    opened = seconds() - opened;
    file = fopen(argv[9], "wb");
    if (!file || fwrite(y, sizeof(double), (size_t)((steps + 1) * n_out), file) != (size_t)((steps + 1) * n_out))
        return 2;
    fclose(file);
    printf("%.6f %.6f\n", looped, opened);
    free(u);
    free(y);
    free(slope);
    free(in_vr);
    free(out_vr);
    free(order);
    return 0;
}
