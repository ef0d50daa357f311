/* driver_common.h: what fmi2_driver.c and fmi3_driver.c share: counting unexpected statuses, looking up FMI
 * functions in the binary, and opening the binary named on the command line "BINARY.so TOKEN N_INPUTS N_OUTPUTS".
 * Included by exactly one source file per driver program, so its static definitions are the program's own.
 */
#ifndef DRIVER_COMMON_H
#define DRIVER_COMMON_H

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

static int failures = 0;

/* Counts a failure (and says which call) when `call` returns a status of type `status_type` other than `expected`. */
#define EXPECT_STATUS(status_type, call, expected)                                                   \
    do {                                                                                             \
        status_type got_ = (call);                                                                   \
        if (got_ != (expected)) {                                                                    \
            fprintf(stderr, "line %d: %s returned %d, expected %d\n", __LINE__, #call, got_, expected); \
            failures++;                                                                              \
        }                                                                                            \
    } while (0)

#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)

/* The binary opened from the command line with the counts of inputs and outputs (at most 16 each), or NULL with
 * *code set to the exit code: 2 for bad arguments, 3 when the binary does not load. */
static void *open_binary(int argc, char **argv, int *n_in, int *n_out, int *code) {
    void *lib;
    if (argc != 5) {
        *code = 2;
        return NULL;
    }
    *n_in = atoi(argv[3]);
    *n_out = atoi(argv[4]);
    if (*n_in > 16 || *n_out > 16) {
        *code = 2;
        return NULL;
    }
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "%s\n", dlerror());
        *code = 3;
    }
    return lib;
}

#endif /* DRIVER_COMMON_H */
