/* A plain FMI 2 master for a system FMU's binary on any platform (dlopen on POSIX, LoadLibrary on Windows), so that
 * the binaries of one system FMU can be compared across platforms (test_system_fmu_platforms.py): instantiate from
 * the resources' URI, set the drive at t_0 in Initialization Mode, then `steps` steps of 1 ms, each setting the drive
 * at t_n and its slopes, doStep, and printing every output ("step K y0 y1 ...", 17 significant digits).
 * The drive is computed with + and * alone (no libm), the same bits on every platform.
 * Exits 0 only if every call returns fmi2OK; says "N unexpected statuses" on stderr.
 * Usage: system_platform_driver LIBRARY GUID RESOURCE_URI N_INPUTS N_OUTPUTS STEPS */
#include <stdio.h>
#include <stdlib.h>

#include "driver_common.h" /* tests/fmu/: the loader, status counting and printing of fmi2_driver.c */
#include "fmi2Functions.h"

#define STEP 1e-3
#define MAX_VARIABLES 256

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    (void)category;
    fprintf(stderr, "[%s %d] %s\n", name, (int)status, message);
}

#define EXPECT_OK(call) EXPECT_STATUS(fmi2Status, call, fmi2OK)

/* The drive: per input, a lightly damped oscillator driven by a pseudo-random sequence (a linear congruential
 * generator), stepped with + and * alone so that every platform computes the same bits; `value` its position [m] and
 * `slope` its velocity [m/s] at the step's start. */
typedef struct {
    double x, v;
    unsigned long long seed;
} oscillator;

static void advance(oscillator *o) {
    const double w = 2.0 * 3.141592653589793 * 2.5, zeta = 0.2, h = STEP;
    double noise;
    o->seed = o->seed * 6364136223846793005ULL + 1442695040888963407ULL;
    noise = (double)(o->seed >> 11) / 9007199254740992.0 * 2.0 - 1.0; /* [-1, 1) */
    o->x += h * o->v;
    o->v += h * (-w * w * o->x - 2.0 * zeta * w * o->v + 20.0 * noise);
}

int main(int argc, char **argv) {
    library_t lib;
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2ValueReference in_vr[MAX_VARIABLES], out_vr[MAX_VARIABLES];
    fmi2Integer order[MAX_VARIABLES];
    fmi2Real in[MAX_VARIABLES], slope[MAX_VARIABLES], out[MAX_VARIABLES];
    oscillator drive[MAX_VARIABLES];
    fmi2Component c;
    int n_in, n_out, steps, i, k;
    if (argc != 7) return 2;
    n_in = atoi(argv[4]);
    n_out = atoi(argv[5]);
    steps = atoi(argv[6]);
    if (n_in < 0 || n_out < 1 || n_in > MAX_VARIABLES || n_out > MAX_VARIABLES || steps < 1) return 2;
    lib = load_library(argv[1]);
    if (!lib) return 3;
    {
        LOAD(fmi2Instantiate);
        LOAD(fmi2SetupExperiment);
        LOAD(fmi2EnterInitializationMode);
        LOAD(fmi2ExitInitializationMode);
        LOAD(fmi2SetReal);
        LOAD(fmi2SetRealInputDerivatives);
        LOAD(fmi2GetReal);
        LOAD(fmi2DoStep);
        LOAD(fmi2Terminate);
        LOAD(fmi2FreeInstance);
        if (!fmi2Instantiate || !fmi2SetRealInputDerivatives || !fmi2DoStep || !fmi2FreeInstance) return 3;
        /* The system FMU's value references: its inputs first (0 .. n_in - 1), then its outputs. */
        for (i = 0; i < n_in; i++) {
            in_vr[i] = (fmi2ValueReference)i;
            order[i] = 1;
            drive[i].x = drive[i].v = 0.0;
            drive[i].seed = 12345ULL + (unsigned long long)i;
        }
        for (i = 0; i < n_out; i++) out_vr[i] = (fmi2ValueReference)(n_in + i);
        c = fmi2Instantiate("car", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False, fmi2False);
        if (c == NULL) {
            fprintf(stderr, "fmi2Instantiate failed\n");
            return 4;
        }
        EXPECT_OK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
        EXPECT_OK(fmi2EnterInitializationMode(c));
        for (i = 0; i < n_in; i++) in[i] = drive[i].x;
        EXPECT_OK(fmi2SetReal(c, in_vr, (size_t)n_in, in));
        EXPECT_OK(fmi2ExitInitializationMode(c));
        for (k = 0; k < steps; k++) {
            double t = k * STEP;
            for (i = 0; i < n_in; i++) {
                in[i] = drive[i].x;
                slope[i] = drive[i].v;
                advance(&drive[i]);
            }
            EXPECT_OK(fmi2SetReal(c, in_vr, (size_t)n_in, in));
            EXPECT_OK(fmi2SetRealInputDerivatives(c, in_vr, (size_t)n_in, order, slope));
            EXPECT_OK(fmi2DoStep(c, t, STEP, fmi2True));
            EXPECT_OK(fmi2GetReal(c, out_vr, (size_t)n_out, out));
            print_outputs("step", k + 1, out, n_out);
        }
        EXPECT_OK(fmi2Terminate(c));
        fmi2FreeInstance(c);
    }
    fprintf(stderr, "%d unexpected statuses\n", failures);
    return failures == 0 ? 0 : 1;
}
