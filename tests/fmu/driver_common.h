/* driver_common.h: what fmi2_driver.c, fmi3_driver.c and tests/cosim/container/system_platform_driver.c share:
 * counting unexpected statuses, loading the FMU's binary (dlopen on POSIX, LoadLibrary on Windows), opening the
 * binary named on the command line
 * "BINARY TOKEN N_INPUTS N_OUTPUTS" and printing outputs for the cross-platform comparison.
 * Included by exactly one source file per driver program, so its static definitions are the program's own.
 */
#ifndef DRIVER_COMMON_H
#define DRIVER_COMMON_H

#include <stdio.h>
#include <stdlib.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE library_t;
/* GetProcAddress returns a generic function pointer; going through void (*)(void) is the cast C allows. */
#define LOAD(name) name##TYPE *name = (name##TYPE *)(void (*)(void))GetProcAddress(lib, #name)
#define close_library(lib) FreeLibrary(lib)
#else
#include <dlfcn.h>
typedef void *library_t;
#define LOAD(name) name##TYPE *name = (name##TYPE *)dlsym(lib, #name)
#define close_library(lib) dlclose(lib)
#endif

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

/* The shared library at `path`, or NULL after saying why on stderr. */
static library_t load_library(const char *path) {
    library_t lib;
#ifdef _WIN32
    lib = LoadLibraryA(path);
    if (!lib) fprintf(stderr, "LoadLibrary(%s) failed: error %lu\n", path, (unsigned long)GetLastError());
#else
    lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!lib) fprintf(stderr, "%s\n", dlerror());
#endif
    return lib;
}

/* The binary opened from the command line with the counts of inputs and outputs (at most 16 each), or NULL with
 * *code set to the exit code: 2 for bad arguments, 3 when the binary does not load. (A driver with other arguments
 * loads with `load_library` and leaves this unused.) */
#if defined(__GNUC__)
__attribute__((unused))
#endif
static library_t open_binary(int argc, char **argv, int *n_in, int *n_out, int *code) {
    library_t lib;
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
    lib = load_library(argv[1]);
    if (!lib) *code = 3;
    return lib;
}

/* One stdout line "TAG K y0 y1 ...", every value with 17 significant digits (enough to round-trip a double). */
static void print_outputs(const char *tag, int k, const double *out, int n_out) {
    int i;
    printf("%s %d", tag, k);
    for (i = 0; i < n_out; i++) printf(" %.17g", out[i]);
    printf("\n");
}

#endif /* DRIVER_COMMON_H */
