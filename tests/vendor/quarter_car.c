/* A vendor-style quarter car as an FMI 2.0 co-simulation FMU, written apart from nnfmu's generators for the tests:
 * what a user's vehicle model from another tool looks like to `nnfmu cosim`.
 *
 * Sprung mass m_s on the suspension spring k_s and the external damper (force F_damper, an input), unsprung mass m_u
 * on the tyre spring k_t over the road displacement zr. States from static equilibrium (no gravity): body z_s, v_s,
 * wheel z_u, v_u. doStep integrates with `substeps` classical RK4 steps; both inputs are held over the communication
 * step (canInterpolateInputs = false: this FMU ignores input derivatives, as many vendor models do).
 *
 * Sign convention: x_damper = z_s - z_u (extension positive), v_damper its rate; F_damper > 0 resists extension:
 *   m_s a_s = -k_s x_damper - F_damper,   m_u a_u = k_s x_damper + F_damper - k_t (z_u - zr).
 * Units as Modelica tools spell them: a_body and a_spindle in m/s2, z_body in mm, F_tyre in kN (see the
 * modelDescription.xml that tests/vendor/vendor_fmu.py writes beside this source). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"

enum { VR_ZR = 0, VR_F_DAMPER = 1, VR_X_DAMPER = 2, VR_V_DAMPER = 3, VR_A_BODY = 4, VR_A_SPINDLE = 5,
       VR_Z_BODY = 6, VR_F_TYRE = 7, VR_M_S = 10, VR_M_U = 11, VR_K_S = 12, VR_K_T = 13, N_REALS = 14 };
enum { VR_SUBSTEPS = 0 };
#define MAX_SUBSTEPS 10000
#ifndef V_DAMPER_SCALE
#define V_DAMPER_SCALE 1.0 /* 1000.0: v_damper in mm/s (the variant tests/vendor/vendor_fmu.py builds for it) */
#endif

typedef struct {
    fmi2CallbackFunctions callbacks;
    char name[64];
    double r[N_REALS]; /* inputs and parameters by value reference */
    double x[4];       /* z_s, v_s, z_u, v_u */
    int substeps;
    double time;
} Model;


static void say(Model *m, fmi2Status status, const char *message) {
    if (m->callbacks.logger) m->callbacks.logger(m->callbacks.componentEnvironment, m->name, status, "logStatusError",
                                                 "%s", message);
}

static void derivatives(const Model *m, const double *x, double *dx) {
    double deflection = x[0] - x[2];
    double spring = m->r[VR_K_S] * deflection + m->r[VR_F_DAMPER];
    double tyre = m->r[VR_K_T] * (x[2] - m->r[VR_ZR]);
    dx[0] = x[1];
    dx[1] = -spring / m->r[VR_M_S];
    dx[2] = x[3];
    dx[3] = (spring - tyre) / m->r[VR_M_U];
}

static double output(const Model *m, fmi2ValueReference vr) {
    double dx[4];
    derivatives(m, m->x, dx);
    switch (vr) {
    case VR_X_DAMPER: return m->x[0] - m->x[2];
    case VR_V_DAMPER: return V_DAMPER_SCALE * (m->x[1] - m->x[3]);
    case VR_A_BODY: return dx[1];
    case VR_A_SPINDLE: return dx[3];
    case VR_Z_BODY: return 1e3 * m->x[0];                                  /* mm */
    case VR_F_TYRE: return 1e-3 * m->r[VR_K_T] * (m->x[2] - m->r[VR_ZR]); /* kN, compression negative */
    default: return m->r[vr];
    }
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String location,
                              const fmi2CallbackFunctions *callbacks, fmi2Boolean visible, fmi2Boolean logging) {
    Model *m;
    (void)location, (void)visible, (void)logging;
    if (type != fmi2CoSimulation || strcmp(guid, "{5e1d0a7c-vendor-quarter-car-0001}") != 0) return NULL;
    m = (Model *)calloc(1, sizeof(Model));
    if (m == NULL) return NULL;
    m->callbacks = *callbacks;
    strncpy(m->name, name ? name : "quarter_car", sizeof(m->name) - 1);
    m->r[VR_M_S] = 400.0;
    m->r[VR_M_U] = 40.0;
    m->r[VR_K_S] = 20e3;
    m->r[VR_K_T] = 200e3;
    m->substeps = 4;
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tol, fmi2Real tolerance, fmi2Real start, fmi2Boolean stop,
                               fmi2Real stop_time) {
    (void)tol, (void)tolerance, (void)stop, (void)stop_time;
    ((Model *)c)->time = start;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { (void)c; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { (void)c; return fmi2OK; }

fmi2Status fmi2Reset(fmi2Component c) {
    Model *m = (Model *)c;
    memset(m->x, 0, sizeof(m->x));
    m->r[VR_ZR] = m->r[VR_F_DAMPER] = 0.0;
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Model *m = (Model *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_REALS) return fmi2Error;
        value[i] = output(m, vr[i]);
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Model *m = (Model *)c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_REALS || (vr[i] > VR_F_DAMPER && vr[i] < VR_M_S)) {
            say(m, fmi2Error, "fmi2SetReal: not an input or parameter");
            return fmi2Error;
        }
        if (!isfinite(value[i])) {
            say(m, fmi2Error, "fmi2SetReal: a value is not finite");
            return fmi2Error;
        }
        m->r[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer value[]) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_SUBSTEPS) return fmi2Error;
        value[i] = ((Model *)c)->substeps;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer value[]) {
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_SUBSTEPS || value[i] < 1 || value[i] > MAX_SUBSTEPS) return fmi2Error;
        ((Model *)c)->substeps = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean no_prior) {
    Model *m = (Model *)c;
    double dt, k[4][4], y[4];
    int s, i, j;
    (void)no_prior;
    if (!(h > 0.0)) {
        say(m, fmi2Error, "fmi2DoStep: the step must be positive");
        return fmi2Error;
    }
    dt = h / m->substeps;
    for (s = 0; s < m->substeps; s++) {
        derivatives(m, m->x, k[0]);
        for (j = 1; j < 4; j++) {
            double f = j == 3 ? dt : 0.5 * dt;
            for (i = 0; i < 4; i++) y[i] = m->x[i] + f * k[j - 1][i];
            derivatives(m, y, k[j]);
        }
        for (i = 0; i < 4; i++) m->x[i] += dt / 6.0 * (k[0][i] + 2.0 * k[1][i] + 2.0 * k[2][i] + k[3][i]);
    }
    m->time = t + h;
    return fmi2OK;
}

/* What a vendor FMU typically leaves out: each returns fmi2Error. */
const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    (void)c, (void)on, (void)n, (void)cat;
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    (void)c, (void)vr, (void)v;
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    (void)c, (void)vr, (void)v;
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    (void)c, (void)vr, (void)v;
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    (void)c, (void)vr, (void)v;
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c, (void)s; return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { (void)c, (void)s; return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { (void)c, (void)s; return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    (void)c, (void)s, (void)n;
    return fmi2Error;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    (void)c, (void)s, (void)b, (void)n;
    return fmi2Error;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    (void)c, (void)b, (void)n, (void)s;
    return fmi2Error;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]) {
    (void)c, (void)u, (void)nu, (void)z, (void)nz, (void)dv, (void)dz;
    return fmi2Error;
}
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr, (void)order, (void)value;
    if (n) say((Model *)c, fmi2Error, "fmi2SetRealInputDerivatives: this FMU cannot interpolate its inputs");
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)c, (void)vr, (void)order, (void)value;
    return n ? fmi2Error : fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { (void)c; return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind k, fmi2Status *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind k, fmi2Real *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind k, fmi2Integer *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind k, fmi2Boolean *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind k, fmi2String *v) {
    (void)c, (void)k, (void)v;
    return fmi2Error;
}
