/* fmi3_driver.c: a minimal FMI 3.0 co-simulation master for test_memcheck.py, run under valgrind or sanitizers.
 *
 * Usage: fmi3_driver BINARY TOKEN N_INPUTS N_OUTPUTS   (BINARY: the .so on POSIX, the .dll on Windows)
 * The FMI 3 counterpart of fmi2_driver.c: wrong token, two instances, initialisation, steps of changing size,
 * outputs, flag, time and directional derivatives read, FMU state get/set/serialise/deserialise/free, refused NaN
 * input and refused calls, unsupported functions, reset, termination and freeing. Exits 0 only if every status is the one expected.
 * Prints the outputs after every step (stdout), so runs of one FMU's binaries on two platforms can be compared.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "driver_common.h"
#include "fmi3Functions.h"

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    fprintf(stderr, "[%d %s] %s\n", (int)status, category, message);
}

#define EXPECT(call, expected) EXPECT_STATUS(fmi3Status, call, expected)

int main(int argc, char **argv) {
    library_t lib;
    fmi3Instance a, b;
    fmi3ValueReference in_vr[16], out_vr[16], flag_vr, time_vr;
    fmi3Float64 in[16], out[16], seed[16], now = 0.0, last = 0.0;
    fmi3FMUState state = NULL, restored = NULL;
    fmi3Byte *buffer;
    fmi3Boolean flag, event, terminate, early;
    size_t size = 0;
    int n_in = 0, n_out = 0, code = 0, i, k;

    lib = open_binary(argc, argv, &n_in, &n_out, &code);
    if (!lib) return code;
    {
        LOAD(fmi3InstantiateCoSimulation);
        LOAD(fmi3FreeInstance);
        LOAD(fmi3EnterInitializationMode);
        LOAD(fmi3ExitInitializationMode);
        LOAD(fmi3SetFloat64);
        LOAD(fmi3GetFloat64);
        LOAD(fmi3GetBoolean);
        LOAD(fmi3GetInt32);
        LOAD(fmi3DoStep);
        LOAD(fmi3GetDirectionalDerivative);
        LOAD(fmi3GetFMUState);
        LOAD(fmi3SetFMUState);
        LOAD(fmi3FreeFMUState);
        LOAD(fmi3SerializedFMUStateSize);
        LOAD(fmi3SerializeFMUState);
        LOAD(fmi3DeserializeFMUState);
        LOAD(fmi3EnterEventMode);
        LOAD(fmi3Terminate);
        LOAD(fmi3Reset);
        fmi3Int32 ignored;

        for (i = 0; i < n_in; i++) in_vr[i] = (fmi3ValueReference)i;
        for (i = 0; i < n_out; i++) out_vr[i] = (fmi3ValueReference)(n_in + i);
        flag_vr = (fmi3ValueReference)(n_in + n_out); /* extrapolating, then filter_cutoff, output_gain, time */
        time_vr = flag_vr + 3;

        if (fmi3InstantiateCoSimulation("wrong", "{not-the-token}", "", fmi3False, fmi3True, fmi3False, fmi3False,
                                        NULL, 0, NULL, logger, NULL)) {
            fprintf(stderr, "a wrong token was accepted\n");
            failures++;
        }
        a = fmi3InstantiateCoSimulation("a", argv[2], "", fmi3False, fmi3True, fmi3False, fmi3False, NULL, 0, NULL,
                                        logger, NULL);
        b = fmi3InstantiateCoSimulation("b", argv[2], "", fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                                        NULL, NULL); /* no logger at all */
        if (!a || !b) return 4;

        EXPECT(fmi3DoStep(a, 0.0, 1e-3, fmi3True, &event, &terminate, &early, &last), fmi3Error);
        EXPECT(fmi3EnterInitializationMode(a, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
        for (i = 0; i < n_in; i++) in[i] = 0.01 * (i + 1);
        EXPECT(fmi3SetFloat64(a, in_vr, (size_t)n_in, in, (size_t)n_in), fmi3OK);
        EXPECT(fmi3SetFloat64(a, in_vr, (size_t)n_in, in, (size_t)n_in + 1), fmi3Error); /* nValues mismatch */
        EXPECT(fmi3GetFloat64(a, out_vr, (size_t)n_out, out, (size_t)n_out), fmi3OK);
        EXPECT(fmi3ExitInitializationMode(a), fmi3OK);
        EXPECT(fmi3EnterInitializationMode(b, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
        EXPECT(fmi3ExitInitializationMode(b), fmi3OK);

        for (k = 0; k < 2000; k++) {
            double h = (k % 3 == 0) ? 2.5e-3 : 0.4e-3;
            for (i = 0; i < n_in; i++) in[i] = 1.3 * sin(0.01 * k + i);
            EXPECT(fmi3SetFloat64(a, in_vr, (size_t)n_in, in, (size_t)n_in), fmi3OK);
            EXPECT(fmi3DoStep(a, now, h, fmi3True, &event, &terminate, &early, &last), fmi3OK);
            EXPECT(fmi3DoStep(b, now, h, fmi3True, &event, &terminate, &early, &last), fmi3OK);
            now += h;
            EXPECT(fmi3GetFloat64(a, out_vr, (size_t)n_out, out, (size_t)n_out), fmi3OK);
            print_outputs("step", k, out, n_out);
            EXPECT(fmi3GetBoolean(a, &flag_vr, 1, &flag, 1), fmi3OK);
            if (k == 1000) EXPECT(fmi3GetFMUState(a, &state), fmi3OK);
            if (k % 500 == 0) { /* d(outputs)/d(inputs) along the seed 1, 2, ...; refused: an input unknown, sizes */
                for (i = 0; i < n_in; i++) seed[i] = i + 1.0;
                EXPECT(fmi3GetDirectionalDerivative(a, out_vr, (size_t)n_out, in_vr, (size_t)n_in, seed, (size_t)n_in,
                                                    out, (size_t)n_out), fmi3OK);
                print_outputs("derivative", k, out, n_out);
                EXPECT(fmi3GetDirectionalDerivative(a, in_vr, 1, in_vr, 1, seed, 1, out, 1), fmi3Error);
                EXPECT(fmi3GetDirectionalDerivative(a, out_vr, 1, in_vr, 1, seed, 2, out, 1), fmi3Error);
            }
        }
        EXPECT(fmi3GetFloat64(a, &time_vr, 1, out, 1), fmi3OK);
        if (out[0] != now || last != now) {
            fprintf(stderr, "time %g / last successful time %g, expected %g\n", out[0], last, now);
            failures++;
        }
        EXPECT(fmi3GetFMUState(a, &state), fmi3OK); /* overwrite in place */
        EXPECT(fmi3SerializedFMUStateSize(a, state, &size), fmi3OK);
        buffer = (fmi3Byte *)malloc(size);
        EXPECT(fmi3SerializeFMUState(a, state, buffer, size), fmi3OK);
        EXPECT(fmi3DeserializeFMUState(a, buffer, size, &restored), fmi3OK);
        EXPECT(fmi3DeserializeFMUState(a, buffer, size + 1, &restored), fmi3Error);
        free(buffer);
        EXPECT(fmi3SetFMUState(a, restored), fmi3OK);
        EXPECT(fmi3DoStep(a, now, 1e-3, fmi3True, &event, &terminate, &early, &last), fmi3OK);
        EXPECT(fmi3GetFloat64(a, out_vr, (size_t)n_out, out, (size_t)n_out), fmi3OK);
        print_outputs("restored", 0, out, n_out);
        EXPECT(fmi3FreeFMUState(a, &state), fmi3OK);
        EXPECT(fmi3FreeFMUState(a, &restored), fmi3OK);

        in[0] = NAN;
        EXPECT(fmi3SetFloat64(a, in_vr, 1, in, 1), fmi3Error);
        EXPECT(fmi3GetInt32(a, in_vr, 1, &ignored, 1), fmi3Error);
        EXPECT(fmi3EnterEventMode(a), fmi3Error);
        EXPECT(fmi3Terminate(a), fmi3OK);
        EXPECT(fmi3Reset(a), fmi3OK);
        EXPECT(fmi3EnterInitializationMode(a, fmi3False, 0.0, 0.0, fmi3False, 0.0), fmi3OK);
        EXPECT(fmi3ExitInitializationMode(a), fmi3OK);
        EXPECT(fmi3DoStep(a, 0.0, 1e-3, fmi3True, &event, &terminate, &early, &last), fmi3OK);
        EXPECT(fmi3Terminate(a), fmi3OK);
        fmi3FreeInstance(a);
        fmi3FreeInstance(b);
    }
    close_library(lib);
    fprintf(stderr, "%d unexpected statuses\n", failures);
    return failures == 0 ? 0 : 1;
}
