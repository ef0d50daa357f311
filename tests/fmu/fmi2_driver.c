/* fmi2_driver.c: a minimal FMI 2.0 co-simulation master for test_memcheck.py, run under valgrind.
 *
 * Usage: fmi2_driver BINARY GUID N_INPUTS N_OUTPUTS   (BINARY: the .so on POSIX, the .dll on Windows)
 * Exercises every path of the glue: a wrong GUID, two instances, initialisation, many steps with changing step
 * sizes, outputs, flags and directional derivatives read, FMU state get/set/serialise/deserialise/free, a refused
 * NaN input, a refused call, reset and re-initialisation, termination and freeing. Exits 0 only if every status is the one expected.
 * Prints the outputs after every step (stdout), so runs of one FMU's binaries on two platforms can be compared.
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "driver_common.h"
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    va_list args;
    (void)env;
    va_start(args, message);
    fprintf(stderr, "[%s %d %s] ", name, (int)status, category);
    vfprintf(stderr, message, args);
    fprintf(stderr, "\n");
    va_end(args);
}

#define EXPECT(call, expected) EXPECT_STATUS(fmi2Status, call, expected)

int main(int argc, char **argv) {
    library_t lib;
    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component a, b;
    fmi2ValueReference in_vr[16], out_vr[16], flag_vr;
    fmi2Real in[16], out[16], seed[16], t = 0.0;
    fmi2FMUstate state = NULL, restored = NULL;
    fmi2Byte *buffer;
    size_t size = 0;
    fmi2Boolean flag;
    int n_in = 0, n_out = 0, code = 0, i, k;

    lib = open_binary(argc, argv, &n_in, &n_out, &code);
    if (!lib) return code;
    {
        LOAD(fmi2Instantiate);
        LOAD(fmi2FreeInstance);
        LOAD(fmi2SetupExperiment);
        LOAD(fmi2EnterInitializationMode);
        LOAD(fmi2ExitInitializationMode);
        LOAD(fmi2SetReal);
        LOAD(fmi2GetReal);
        LOAD(fmi2GetBoolean);
        LOAD(fmi2DoStep);
        LOAD(fmi2GetDirectionalDerivative);
        LOAD(fmi2GetFMUstate);
        LOAD(fmi2SetFMUstate);
        LOAD(fmi2FreeFMUstate);
        LOAD(fmi2SerializedFMUstateSize);
        LOAD(fmi2SerializeFMUstate);
        LOAD(fmi2DeSerializeFMUstate);
        LOAD(fmi2Terminate);
        LOAD(fmi2Reset);

        for (i = 0; i < n_in; i++) in_vr[i] = (fmi2ValueReference)i;
        for (i = 0; i < n_out; i++) out_vr[i] = (fmi2ValueReference)(n_in + i);
        flag_vr = (fmi2ValueReference)(n_in + n_out); /* extrapolating follows the outputs */

        if (fmi2Instantiate("wrong", fmi2CoSimulation, "{not-the-guid}", "", &callbacks, fmi2False, fmi2True)) {
            fprintf(stderr, "a wrong GUID was accepted\n");
            failures++;
        }
        a = fmi2Instantiate("a", fmi2CoSimulation, argv[2], "", &callbacks, fmi2False, fmi2True);
        b = fmi2Instantiate("b", fmi2CoSimulation, argv[2], "", &callbacks, fmi2False, fmi2False);
        if (!a || !b) return 4;

        EXPECT(fmi2DoStep(a, 0.0, 1e-3, fmi2True), fmi2Error); /* not initialised yet */
        EXPECT(fmi2SetupExperiment(a, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
        EXPECT(fmi2EnterInitializationMode(a), fmi2OK);
        for (i = 0; i < n_in; i++) in[i] = 0.01 * (i + 1);
        EXPECT(fmi2SetReal(a, in_vr, (size_t)n_in, in), fmi2OK);
        EXPECT(fmi2GetReal(a, out_vr, (size_t)n_out, out), fmi2OK);
        EXPECT(fmi2ExitInitializationMode(a), fmi2OK);
        EXPECT(fmi2SetupExperiment(b, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
        EXPECT(fmi2EnterInitializationMode(b), fmi2OK);
        EXPECT(fmi2ExitInitializationMode(b), fmi2OK);

        for (k = 0; k < 2000; k++) {
            double h = (k % 3 == 0) ? 2.5e-3 : 0.4e-3;
            for (i = 0; i < n_in; i++) in[i] = 1.3 * sin(0.01 * k + i);
            EXPECT(fmi2SetReal(a, in_vr, (size_t)n_in, in), fmi2OK);
            EXPECT(fmi2DoStep(a, t, h, fmi2True), fmi2OK);
            EXPECT(fmi2DoStep(b, t, h, fmi2True), fmi2OK);
            t += h;
            EXPECT(fmi2GetReal(a, out_vr, (size_t)n_out, out), fmi2OK);
            print_outputs("step", k, out, n_out);
            EXPECT(fmi2GetBoolean(a, &flag_vr, 1, &flag), fmi2OK);
            if (k == 1000) EXPECT(fmi2GetFMUstate(a, &state), fmi2OK);
            if (k % 500 == 0) { /* d(outputs)/d(inputs) along the seed 1, 2, ...; a refused input unknown */
                for (i = 0; i < n_in; i++) seed[i] = i + 1.0;
                EXPECT(fmi2GetDirectionalDerivative(a, out_vr, (size_t)n_out, in_vr, (size_t)n_in, seed, out), fmi2OK);
                print_outputs("derivative", k, out, n_out);
                EXPECT(fmi2GetDirectionalDerivative(a, in_vr, 1, in_vr, 1, seed, out), fmi2Error);
            }
        }
        EXPECT(fmi2GetFMUstate(a, &state), fmi2OK); /* overwrite in place */
        EXPECT(fmi2SerializedFMUstateSize(a, state, &size), fmi2OK);
        buffer = (fmi2Byte *)malloc(size);
        EXPECT(fmi2SerializeFMUstate(a, state, buffer, size), fmi2OK);
        EXPECT(fmi2DeSerializeFMUstate(a, buffer, size, &restored), fmi2OK);
        EXPECT(fmi2DeSerializeFMUstate(a, buffer, size - 1, &restored), fmi2Error);
        buffer[0] ^= 0x55;
        EXPECT(fmi2DeSerializeFMUstate(a, buffer, size, &restored), fmi2Error);
        free(buffer);
        EXPECT(fmi2SetFMUstate(a, restored), fmi2OK);
        EXPECT(fmi2DoStep(a, t, 1e-3, fmi2True), fmi2OK);
        EXPECT(fmi2GetReal(a, out_vr, (size_t)n_out, out), fmi2OK);
        print_outputs("restored", 0, out, n_out);
        EXPECT(fmi2FreeFMUstate(a, &state), fmi2OK);
        EXPECT(fmi2FreeFMUstate(a, &restored), fmi2OK);

        in[0] = NAN;
        EXPECT(fmi2SetReal(a, in_vr, 1, in), fmi2Error);
        EXPECT(fmi2DoStep(a, t + 5.0, 1e-3, fmi2True), fmi2Error); /* not the FMU's time */
        EXPECT(fmi2Terminate(a), fmi2OK);
        EXPECT(fmi2Reset(a), fmi2OK);
        EXPECT(fmi2SetupExperiment(a, fmi2False, 0.0, 0.0, fmi2False, 0.0), fmi2OK);
        EXPECT(fmi2EnterInitializationMode(a), fmi2OK);
        EXPECT(fmi2ExitInitializationMode(a), fmi2OK);
        EXPECT(fmi2DoStep(a, 0.0, 1e-3, fmi2True), fmi2OK);
        EXPECT(fmi2Terminate(a), fmi2OK);
        fmi2FreeInstance(a);
        fmi2FreeInstance(b);
    }
    close_library(lib);
    fprintf(stderr, "%d unexpected statuses\n", failures);
    return failures == 0 ? 0 : 1;
}
