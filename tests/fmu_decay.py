"""A small FMI 2.0 co-simulation FMU with a closed form, built from C source for the tests.

``decay``: the state ``x`` of ``dx/dt = -k x``, ``x(0) = x0``, advanced exactly by
``x(t + h) = x(t) exp(-k h)``, so ``x(t) = x0 exp(-k t)`` to round-off and a test needs no
integration tolerance. Its parameters:

- ``x0`` [m] (start 1), ``k`` [1/s] (start 0.5);
- ``x_max`` [m] (start 1e300): ``fmi2DoStep`` returns ``fmi2Error`` (logging why) while
  ``x > x_max``: a failing simulation;
- ``t_end`` [s] (start 1e300): from there on ``fmi2DoStep`` returns ``fmi2Discard`` and the
  FMU says it has terminated: a simulation that stops early.

Outputs ``x`` [m] and ``rate = -k x`` [m/s].

The binary also implements model exchange (``x`` the continuous state, ``rate`` its
derivative; the simulator's solver integrates it, ``x_max`` and ``t_end`` do not apply), so the
same library declared as a model-exchange-only FMU tests that path.

:func:`build` writes the source and ``modelDescription.xml``, compiles the shared library with
``cc`` against the FMI headers FMPy ships, and zips the three into the ``.fmu``.
"""

from __future__ import annotations

import shutil
import subprocess
import zipfile
from pathlib import Path

GUID = "{8c4e810f-3df3-4a00-8276-176fa3c9f002}"

SOURCE = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { X0, K, X_MAX, T_END, X, RATE, NVARS };

typedef struct {
    double v[NVARS];
    double time;
    int terminated;
    fmi2CallbackFunctions cb;
    char name[64];
} Decay;

static void defaults(Decay *d) {
    d->v[X0] = 1.0; d->v[K] = 0.5; d->v[X_MAX] = 1e300; d->v[T_END] = 1e300;
    d->time = 0.0; d->terminated = 0;
}

static void outputs(Decay *d) { d->v[RATE] = -d->v[K] * d->v[X]; }

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                               const fmi2String cats[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String resources, const fmi2CallbackFunctions *cb,
                              fmi2Boolean visible, fmi2Boolean logging) {
    Decay *d;
    if (strcmp(guid, "GUID")) return NULL;
    d = calloc(1, sizeof *d);
    if (!d) return NULL;
    d->cb = *cb;
    snprintf(d->name, sizeof d->name, "%s", name);
    defaults(d);
    return d;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol,
                               fmi2Real start, fmi2Boolean stopDef, fmi2Real stop) {
    ((Decay *)c)->time = start;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Decay *d = c;
    d->v[X] = d->v[X0];
    outputs(d);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults(c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       fmi2Real value[]) {
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NVARS) return fmi2Error;
        value[i] = ((Decay *)c)->v[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       const fmi2Real value[]) {
    for (size_t i = 0; i < n; i++) {
        if (vr[i] > T_END) return fmi2Error;
        ((Decay *)c)->v[vr[i]] = value[i];
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSet) {
    Decay *d = c;
    if (d->v[X] > d->v[X_MAX]) {
        d->cb.logger(d->cb.componentEnvironment, d->name, fmi2Error, "logStatusError",
                     "x = %g exceeds x_max = %g at t = %g", d->v[X], d->v[X_MAX], t);
        return fmi2Error;
    }
    if (t + h > d->v[T_END] + 1e-12) {
        d->terminated = 1;
        return fmi2Discard;
    }
    d->v[X] *= exp(-d->v[K] * h);
    d->time = t + h;
    outputs(d);
    return fmi2OK;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    if (s != fmi2Terminated) return fmi2Discard;
    *v = ((Decay *)c)->terminated;
    return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    if (s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = ((Decay *)c)->time;
    return fmi2OK;
}

/* Model exchange: the solver integrates x' = -k x itself (X_MAX and T_END do not apply). */
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Decay *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Decay *d = c;
    d->v[X] = x[0];
    outputs(d);
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    x[0] = ((Decay *)c)->v[X];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    dx[0] = ((Decay *)c)->v[RATE];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    x[0] = 1.0;
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) { return fmi2OK; }
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    memset(e, 0, sizeof *e);
    return fmi2OK;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter,
                                       fmi2Boolean *terminate) {
    *enter = fmi2False;
    *terminate = fmi2False;
    return fmi2OK;
}

/* What this FMU does not do: every other FMI 2.0 function, present as the standard requires. */
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Integer v[]) { return fmi2Error; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Boolean v[]) { return fmi2Error; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         fmi2String v[]) { return fmi2Error; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Integer v[]) { return fmi2Error; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Boolean v[]) { return fmi2Error; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         const fmi2String v[]) { return fmi2Error; }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n,
                                   fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                        size_t nu, const fmi2ValueReference k[], size_t nk,
                                        const fmi2Real dk[], fmi2Real du[]) {
    return fmi2Error; }
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t n, const fmi2Integer o[], const fmi2Real v[]) {
    return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t n, const fmi2Integer o[], fmi2Real v[]) {
    return fmi2Error; }
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) {
    return fmi2Discard; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) {
    return fmi2Discard; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) {
    return fmi2Discard; }
""".replace('"GUID"', '"' + GUID + '"')

MODEL_DESCRIPTION = f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="decay" guid="{GUID}"
    description="x' = -k x, advanced exactly" numberOfEventIndicators="0">
INTERFACES
  <UnitDefinitions>
    <Unit name="m"><BaseUnit m="1"/></Unit>
    <Unit name="1/s"><BaseUnit s="-1"/></Unit>
    <Unit name="s"><BaseUnit s="1"/></Unit>
    <Unit name="m/s"><BaseUnit m="1" s="-1"/></Unit>
  </UnitDefinitions>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="0.5"/>
  <ModelVariables>
    <ScalarVariable name="x0" valueReference="0" causality="parameter" variability="fixed"
        initial="exact" description="initial state"><Real start="1" unit="m"/></ScalarVariable>
    <ScalarVariable name="k" valueReference="1" causality="parameter" variability="fixed"
        initial="exact" description="decay rate"><Real start="0.5" unit="1/s"/></ScalarVariable>
    <ScalarVariable name="x_max" valueReference="2" causality="parameter" variability="fixed"
        initial="exact" description="largest x a step accepts"><Real start="1e300" unit="m"/>
        </ScalarVariable>
    <ScalarVariable name="t_end" valueReference="3" causality="parameter" variability="fixed"
        initial="exact" description="time the FMU stops at"><Real start="1e300" unit="s"/>
        </ScalarVariable>
    <ScalarVariable name="x" valueReference="4" causality="output" variability="continuous"
        initial="calculated" description="state"><Real unit="m"/></ScalarVariable>
    <ScalarVariable name="rate" valueReference="5" causality="output" variability="continuous"
        initial="calculated" description="dx/dt"><Real unit="m/s" derivative="5"/>
        </ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="5"/><Unknown index="6"/></Outputs>
    <Derivatives><Unknown index="6"/></Derivatives>
    <InitialUnknowns><Unknown index="5"/><Unknown index="6"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


CO_SIMULATION = ('  <CoSimulation modelIdentifier="decay" '
                 'canHandleVariableCommunicationStepSize="true"/>')
MODEL_EXCHANGE = '  <ModelExchange modelIdentifier="decay"/>'


#: The same source, with a crash (abort) where ``x > x_max`` makes a ``doStep`` fail: a binary
#: that takes its process down, as a broken FMU does.
CRASHING = SOURCE.replace("        return fmi2Error;\n    }\n    if (t + h",
                          "        abort();\n    }\n    if (t + h", 1)


def build(folder: Path, interfaces: tuple[str, ...] = (CO_SIMULATION,),
          name: str = "decay.fmu", source: str = SOURCE) -> Path:
    """Compile the FMU into ``folder`` and return its path.

    Parameters
    ----------
    folder : Path
        A folder to build in (the library is compiled once per folder).
    interfaces : tuple of str
        The interface elements its description declares: :data:`CO_SIMULATION` (the
        default), :data:`MODEL_EXCHANGE` (the simulator then integrates ``x' = -k x``), or
        both. The binary implements both.
    name : str
        The file name.
    source : str
        The C source (:data:`SOURCE`, or :data:`CRASHING`); one per folder.

    Returns
    -------
    Path
        ``folder/name``.
    """
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    src = folder / "decay.c"
    src.write_text(source)
    lib = folder / "decay.so"
    if not lib.exists():
        cc = shutil.which("cc")
        assert cc is not None
        subprocess.run([cc, "-shared", "-fPIC", "-O1", "-w", f"-I{headers}", "-o", str(lib),
                        str(src), "-lm"], check=True, capture_output=True)
    fmu = folder / name
    with zipfile.ZipFile(fmu, "w") as z:
        z.writestr("modelDescription.xml",
                   MODEL_DESCRIPTION.replace("INTERFACES", "\n".join(interfaces)))
        z.write(lib, "binaries/linux64/decay.so")
        z.write(src, "sources/decay.c")
    return fmu


def example_params(fmu: Path) -> dict:
    """The ``fmu`` model's parameters for the conformance suite: both inputs, a scalar, a
    series and a two-component scalar, on a 4-step grid."""
    return {"path": str(fmu), "inputs": {"x0": "x0", "k": "k"},
            "outputs": ["x", {"name": "path", "kind": "series", "variable": "x"},
                        {"name": "both", "variable": ["x", "rate"]}],
            "stop_time": 2.0, "output_interval": 0.5}
