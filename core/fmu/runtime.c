/* greybench's FMI 2.0 runtime for an exported model (core/fmu/fmu.h): the standard's C interface
   over the model's generated functions. Written by greybench; the generated part above it defines

     GB_N_STATES, GB_N_INPUTS, GB_N_OUTPUTS, GB_N_PARAMETERS   the counts (each may be 0 except
                                                               the states)
     GB_SLOT_INPUT, GB_SLOT_PARAMETER, GB_SLOT_TIME            where u, theta and t sit in a slot
                                                               vector [x | u | theta | t]
     GB_GUID                                                   the modelDescription's guid
     gb_theta_start[], gb_x_start[], gb_u_start[]              the start values
     gb_state_name[], gb_output_name[]                         for messages
     void gb_drift(const double* slots, double* f)             f(x, u, theta, t), GB_N_STATES values
     void gb_observation(const double* slots, double* h)       h(x, u, theta, t), GB_N_OUTPUTS
                                                               values
     GB_SUPPORTS(type)                                         whether fmi2Instantiate accepts
                                                               fmi2ModelExchange / fmi2CoSimulation
     GB_RTOL, GB_ATOL                                          Co-Simulation's error control (the
                                                               model's ekf tolerances)

   Value references: the states 0..n-1, their derivatives n..2n-1, the inputs, the outputs, the
   parameters, in that order (modelDescription.xml lists them the same way).

   The state machine is the standard's (FMI 2.0, section 3.2.3 for Model Exchange): a call that
   is not allowed in the instance's state is refused with fmi2Error and a logged message naming
   the function and the state, never a crash.

   With GB_VIRTUAL_SENSOR the generated part is a virtual sensor's, and sensor.c, appended after
   this file, gives the values, the variables and the Co-Simulation step in place of the parts
   marked #ifndef GB_VIRTUAL_SENSOR here. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#define GB_VR_STATE 0
#define GB_VR_DERIVATIVE (GB_N_STATES)
#ifdef GB_VIRTUAL_SENSOR
#define GB_VR_INPUT 0 /* a virtual sensor's Reals start with the inputs (sensor.c) */
#else
#define GB_VR_INPUT (2 * GB_N_STATES)
#endif
#define GB_VR_OUTPUT (GB_VR_INPUT + GB_N_INPUTS)
#define GB_VR_PARAMETER (GB_VR_OUTPUT + GB_N_OUTPUTS)
#define GB_VR_END (GB_VR_PARAMETER + GB_N_PARAMETERS)
#define GB_N_SLOTS (GB_SLOT_TIME + 1)
#define GB_MAX1(k) ((k) > 0 ? (k) : 1)

typedef enum {
  gbInstantiated = 1 << 0,
  gbInitialization = 1 << 1,
  gbEvent = 1 << 2,
  gbContinuousTime = 1 << 3,
  gbStepComplete = 1 << 4,
  gbTerminated = 1 << 5,
  gbError = 1 << 6
} gbState;

typedef struct {
  gbState state;
  fmi2Type type;
  char name[128];
  fmi2CallbackFunctions callbacks;
  fmi2Boolean logging;
  double time;
  double x[GB_N_STATES];
  double u[GB_MAX1(GB_N_INPUTS)];
  double theta[GB_MAX1(GB_N_PARAMETERS)];
  double du[GB_MAX1(GB_N_INPUTS)]; /* Co-Simulation: the inputs' slopes over the next step */
  double step_start;               /* Co-Simulation: where the current step began */
  double h_hint;                   /* Co-Simulation: the last accepted step's proposal */
  fmi2Boolean jumped;              /* an input or parameter changed since the last event */
  void* sensor;                    /* a virtual sensor's filter (sensor.c) */
} gbInstance;

#ifdef GB_VIRTUAL_SENSOR
static int gb_sensor_new(gbInstance* c);
static void gb_sensor_free(gbInstance* c);
static void gb_sensor_reset(gbInstance* c);
static fmi2Status gb_derivatives(gbInstance* c, double* f);
#endif

static const char* gb_state_text(gbState s) {
  switch (s) {
    case gbInstantiated:
      return "Instantiated";
    case gbInitialization:
      return "Initialization Mode";
    case gbEvent:
      return "Event Mode";
    case gbContinuousTime:
      return "Continuous-Time Mode";
    case gbStepComplete:
      return "Step Complete";
    case gbTerminated:
      return "Terminated";
    case gbError:
      return "Error";
  }
  return "?";
}

static void gb_log(gbInstance* c, fmi2Status status, const char* category, const char* format,
                   ...) {
  char message[512];
  va_list args;
  if (!c || !c->callbacks.logger) return;
  if (status == fmi2OK && !c->logging) return;
  va_start(args, format);
  vsnprintf(message, sizeof message, format, args);
  va_end(args);
  c->callbacks.logger(c->callbacks.componentEnvironment, c->name, status, category, "%s", message);
}

/* Whether `function` may be called in c's state (one of `allowed`); logs and refuses if not. */
static int gb_allowed(gbInstance* c, const char* function, int allowed) {
  if (!c) return 0;
  if (c->state & allowed) return 1;
  gb_log(c, fmi2Error, "logStatusError", "%s: not allowed in %s", function,
         gb_state_text(c->state));
  return 0;
}

static void gb_slots(const gbInstance* c, double* s) {
  int i;
  for (i = 0; i < GB_N_STATES; ++i) s[i] = c->x[i];
  for (i = 0; i < GB_N_INPUTS; ++i) s[GB_SLOT_INPUT + i] = c->u[i];
  for (i = 0; i < GB_N_PARAMETERS; ++i) s[GB_SLOT_PARAMETER + i] = c->theta[i];
  s[GB_SLOT_TIME] = c->time;
}

#ifndef GB_VIRTUAL_SENSOR
/* f at the instance's (x, u, theta, t); fmi2Error with a message naming the entry if not finite. */
static fmi2Status gb_derivatives(gbInstance* c, double* f) {
  double s[GB_N_SLOTS];
  int i;
  gb_slots(c, s);
  gb_drift(s, f);
  for (i = 0; i < GB_N_STATES; ++i) {
    if (!isfinite(f[i])) {
      gb_log(c, fmi2Error, "logStatusError", "the drift of %s is %s at t = %g", gb_state_name[i],
             isnan(f[i]) ? "not a number" : "infinite", c->time);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

static fmi2Status gb_outputs(gbInstance* c, double* h) {
  double s[GB_N_SLOTS];
  int i;
  gb_slots(c, s);
  gb_observation(s, h);
  for (i = 0; i < GB_N_OUTPUTS; ++i) {
    if (!isfinite(h[i])) {
      gb_log(c, fmi2Error, "logStatusError", "the output %s is %s at t = %g", gb_output_name[i],
             isnan(h[i]) ? "not a number" : "infinite", c->time);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

#endif

/* ---- common functions --------------------------------------------------------------------- */

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component component, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
  gbInstance* c = (gbInstance*)component;
  (void)nCategories;
  (void)categories;
  if (!c) return fmi2Error;
  c->logging = loggingOn;
  return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions* functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn) {
  gbInstance* c;
  gbInstance probe;
  int i;
  (void)fmuResourceLocation;
  (void)visible;
  if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
  memset(&probe, 0, sizeof probe);
  probe.callbacks = *functions;
  probe.logging = fmi2True;
  snprintf(probe.name, sizeof probe.name, "%s", instanceName ? instanceName : "");
  if (!instanceName || !*instanceName) {
    gb_log(&probe, fmi2Error, "logStatusError", "fmi2Instantiate: the instance name is empty");
    return NULL;
  }
  if (!fmuGUID || strcmp(fmuGUID, GB_GUID) != 0) {
    gb_log(&probe, fmi2Error, "logStatusError",
           "fmi2Instantiate: the guid %s is not this FMU's (%s): the modelDescription.xml does not "
           "belong to this binary",
           fmuGUID ? fmuGUID : "(null)", GB_GUID);
    return NULL;
  }
  if (!GB_SUPPORTS(fmuType)) {
    gb_log(&probe, fmi2Error, "logStatusError", "fmi2Instantiate: this FMU is not exported for %s",
           fmuType == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation");
    return NULL;
  }
  c = (gbInstance*)functions->allocateMemory(1, sizeof(gbInstance));
  if (!c) return NULL;
  *c = probe;
#ifdef GB_VIRTUAL_SENSOR
  if (!gb_sensor_new(c)) {
    functions->freeMemory(c);
    return NULL;
  }
  gb_sensor_reset(c);
#endif
  c->logging = loggingOn;
  c->type = fmuType;
  c->state = gbInstantiated;
  for (i = 0; i < GB_N_STATES; ++i) c->x[i] = gb_x_start[i];
  for (i = 0; i < GB_N_INPUTS; ++i) c->u[i] = gb_u_start[i];
  for (i = 0; i < GB_N_PARAMETERS; ++i) c->theta[i] = gb_theta_start[i];
  return c;
}

void fmi2FreeInstance(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!c) return;
#ifdef GB_VIRTUAL_SENSOR
  gb_sensor_free(c);
#endif
  c->callbacks.freeMemory(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component component, fmi2Boolean toleranceDefined,
                               fmi2Real tolerance, fmi2Real startTime, fmi2Boolean stopTimeDefined,
                               fmi2Real stopTime) {
  gbInstance* c = (gbInstance*)component;
  (void)toleranceDefined;
  (void)tolerance;
  (void)stopTimeDefined;
  (void)stopTime;
  if (!gb_allowed(c, "fmi2SetupExperiment", gbInstantiated)) return fmi2Error;
  c->time = startTime;
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2EnterInitializationMode", gbInstantiated)) return fmi2Error;
  c->state = gbInitialization;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2ExitInitializationMode", gbInitialization)) return fmi2Error;
  c->state = c->type == fmi2ModelExchange ? gbEvent : gbStepComplete;
  c->jumped = fmi2False; /* the importer starts its integrator here in any case */
  return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2Terminate", gbEvent | gbContinuousTime | gbStepComplete))
    return fmi2Error;
  c->state = gbTerminated;
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  int i;
  if (!gb_allowed(c, "fmi2Reset",
                  gbInstantiated | gbInitialization | gbEvent | gbContinuousTime | gbStepComplete |
                      gbTerminated | gbError))
    return fmi2Error;
  c->state = gbInstantiated;
  c->time = 0.0;
  c->step_start = 0.0;
  c->h_hint = 0.0;
  c->jumped = fmi2False;
  for (i = 0; i < GB_N_STATES; ++i) c->x[i] = gb_x_start[i];
  for (i = 0; i < GB_N_INPUTS; ++i) {
    c->u[i] = gb_u_start[i];
    c->du[i] = 0.0;
  }
  for (i = 0; i < GB_N_PARAMETERS; ++i) c->theta[i] = gb_theta_start[i];
#ifdef GB_VIRTUAL_SENSOR
  gb_sensor_reset(c);
#endif
  return fmi2OK;
}

/* ---- values ------------------------------------------------------------------------------- */

#ifndef GB_VIRTUAL_SENSOR
fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
  gbInstance* c = (gbInstance*)component;
  double f[GB_N_STATES], h[GB_MAX1(GB_N_OUTPUTS)];
  int have_f = 0, have_h = 0;
  size_t k;
  if (!gb_allowed(
          c, "fmi2GetReal",
          gbInitialization | gbEvent | gbContinuousTime | gbStepComplete | gbTerminated | gbError))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    const fmi2ValueReference r = vr[k];
    if (r < GB_VR_DERIVATIVE) {
      value[k] = c->x[r - GB_VR_STATE];
    } else if (r < GB_VR_INPUT) {
      if (!have_f && gb_derivatives(c, f) != fmi2OK) return fmi2Error;
      have_f = 1;
      value[k] = f[r - GB_VR_DERIVATIVE];
    } else if (r < GB_VR_OUTPUT) {
      value[k] = c->u[r - GB_VR_INPUT];
    } else if (r < GB_VR_PARAMETER) {
      if (!have_h && gb_outputs(c, h) != fmi2OK) return fmi2Error;
      have_h = 1;
      value[k] = h[r - GB_VR_OUTPUT];
    } else if (r < GB_VR_END) {
      value[k] = c->theta[r - GB_VR_PARAMETER];
    } else {
      gb_log(c, fmi2Error, "logStatusError", "fmi2GetReal: no variable has value reference %u",
             (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
  gbInstance* c = (gbInstance*)component;
  size_t k;
  if (!gb_allowed(c, "fmi2SetReal",
                  gbInstantiated | gbInitialization | gbEvent | gbContinuousTime | gbStepComplete))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    const fmi2ValueReference r = vr[k];
    if (r < GB_VR_DERIVATIVE) {
      if (!(c->state & (gbInstantiated | gbInitialization))) {
        gb_log(c, fmi2Error, "logStatusError",
               "fmi2SetReal: the state %s is set before initialisation or by "
               "fmi2SetContinuousStates, not in %s",
               gb_state_name[r], gb_state_text(c->state));
        return fmi2Error;
      }
      c->x[r - GB_VR_STATE] = value[k];
    } else if (r >= GB_VR_INPUT && r < GB_VR_OUTPUT) {
      if (c->u[r - GB_VR_INPUT] != value[k]) c->jumped = fmi2True;
      c->u[r - GB_VR_INPUT] = value[k];
    } else if (r >= GB_VR_PARAMETER && r < GB_VR_END) {
      if (c->state & gbContinuousTime) {
        gb_log(c, fmi2Error, "logStatusError",
               "fmi2SetReal: a tunable parameter is set in Event Mode, not in %s",
               gb_state_text(c->state));
        return fmi2Error;
      }
      if (c->theta[r - GB_VR_PARAMETER] != value[k]) c->jumped = fmi2True;
      c->theta[r - GB_VR_PARAMETER] = value[k];
    } else {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2SetReal: value reference %u is not a state, an input or a parameter (a "
             "derivative or an output is computed, never set)",
             (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

#endif

/* No integer, boolean or string variables: only empty requests succeed. */
#define GB_NO_VARIABLES(function, value_type, const_)                                        \
  fmi2Status function(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,    \
                      const_ value_type value[]) {                                           \
    gbInstance* c = (gbInstance*)component;                                                  \
    (void)vr;                                                                                \
    (void)value;                                                                             \
    if (!c) return fmi2Error;                                                                \
    if (nvr == 0) return fmi2OK;                                                             \
    gb_log(c, fmi2Error, "logStatusError", "%s: this FMU has no such variables", #function); \
    return fmi2Error;                                                                        \
  }
#ifndef GB_VIRTUAL_SENSOR
GB_NO_VARIABLES(fmi2GetInteger, fmi2Integer, )
GB_NO_VARIABLES(fmi2GetBoolean, fmi2Boolean, )
GB_NO_VARIABLES(fmi2GetString, fmi2String, )
GB_NO_VARIABLES(fmi2SetInteger, fmi2Integer, const)
GB_NO_VARIABLES(fmi2SetBoolean, fmi2Boolean, const)
GB_NO_VARIABLES(fmi2SetString, fmi2String, const)
#endif

/* ---- what this FMU does not provide (modelDescription.xml says so) ----------------------- */

static fmi2Status gb_not_provided(fmi2Component component, const char* function) {
  gb_log((gbInstance*)component, fmi2Error, "logStatusError",
         "%s: not provided by this FMU (see its modelDescription.xml)", function);
  return fmi2Error;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate* s) {
  (void)s;
  return gb_not_provided(c, "fmi2GetFMUstate");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
  (void)s;
  return gb_not_provided(c, "fmi2SetFMUstate");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate* s) {
  (void)s;
  return gb_not_provided(c, "fmi2FreeFMUstate");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t* size) {
  (void)s;
  (void)size;
  return gb_not_provided(c, "fmi2SerializedFMUstateSize");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t size) {
  (void)s;
  (void)b;
  (void)size;
  return gb_not_provided(c, "fmi2SerializeFMUstate");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t size,
                                   fmi2FMUstate* s) {
  (void)b;
  (void)size;
  (void)s;
  return gb_not_provided(c, "fmi2DeSerializeFMUstate");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
  (void)u;
  (void)nu;
  (void)z;
  (void)nz;
  (void)dv;
  (void)dz;
  return gb_not_provided(c, "fmi2GetDirectionalDerivative");
}

/* ---- Model Exchange ----------------------------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2EnterEventMode", gbEvent | gbContinuousTime)) return fmi2Error;
  c->state = gbEvent;
  return fmi2OK;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component component, fmi2EventInfo* info) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2NewDiscreteStates", gbEvent)) return fmi2Error;
  if (!info) return fmi2Error;
  info->newDiscreteStatesNeeded = fmi2False;
  info->terminateSimulation = fmi2False;
  info->nominalsOfContinuousStatesChanged = fmi2False;
  /* An input or a parameter that changed since the last event may have jumped (an importer
     sets a stepped input in Event Mode or just before it, in Continuous-Time Mode). The
     states keep their values, but an integrator that carries history (CVODE's BDF or Adams)
     must restart here, and FMI 2.0's way to ask for that is this flag: fmusim restarts on it
     and on nothing else, and without it CVODE's error test fails just after an input step. A
     restart where the input only moved continuously costs the importer a few small steps. */
  info->valuesOfContinuousStatesChanged = c->jumped;
  c->jumped = fmi2False;
  info->nextEventTimeDefined = fmi2False;
  info->nextEventTime = 0.0;
  return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component component) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2EnterContinuousTimeMode", gbEvent)) return fmi2Error;
  c->state = gbContinuousTime;
  return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component component,
                                       fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode,
                                       fmi2Boolean* terminateSimulation) {
  gbInstance* c = (gbInstance*)component;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (!gb_allowed(c, "fmi2CompletedIntegratorStep", gbContinuousTime)) return fmi2Error;
  if (enterEventMode) *enterEventMode = fmi2False;
  if (terminateSimulation) *terminateSimulation = fmi2False;
  return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component component, fmi2Real time) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2SetTime", gbEvent | gbContinuousTime)) return fmi2Error;
  c->time = time;
  return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component component, const fmi2Real x[], size_t nx) {
  gbInstance* c = (gbInstance*)component;
  size_t i;
  if (!gb_allowed(c, "fmi2SetContinuousStates", gbContinuousTime)) return fmi2Error;
  if (nx != GB_N_STATES || !x) {
    gb_log(c, fmi2Error, "logStatusError",
           "fmi2SetContinuousStates: %u states given, the model has %d", (unsigned)nx, GB_N_STATES);
    return fmi2Error;
  }
  for (i = 0; i < nx; ++i) c->x[i] = x[i];
  return fmi2OK;
}

fmi2Status fmi2GetDerivatives(fmi2Component component, fmi2Real derivatives[], size_t nx) {
  gbInstance* c = (gbInstance*)component;
  if (!gb_allowed(c, "fmi2GetDerivatives", gbEvent | gbContinuousTime | gbTerminated | gbError))
    return fmi2Error;
  if (nx != GB_N_STATES || !derivatives) {
    gb_log(c, fmi2Error, "logStatusError", "fmi2GetDerivatives: %u asked for, the model has %d",
           (unsigned)nx, GB_N_STATES);
    return fmi2Error;
  }
  return gb_derivatives(c, derivatives);
}

fmi2Status fmi2GetEventIndicators(fmi2Component component, fmi2Real indicators[], size_t ni) {
  gbInstance* c = (gbInstance*)component;
  (void)indicators;
  if (!gb_allowed(c, "fmi2GetEventIndicators", gbEvent | gbContinuousTime | gbTerminated | gbError))
    return fmi2Error;
  return ni == 0 ? fmi2OK : fmi2Error;
}

fmi2Status fmi2GetContinuousStates(fmi2Component component, fmi2Real x[], size_t nx) {
  gbInstance* c = (gbInstance*)component;
  size_t i;
  if (!gb_allowed(c, "fmi2GetContinuousStates",
                  gbInitialization | gbEvent | gbContinuousTime | gbTerminated | gbError))
    return fmi2Error;
  if (nx != GB_N_STATES || !x) return fmi2Error;
  for (i = 0; i < nx; ++i) x[i] = c->x[i];
  return fmi2OK;
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component component, fmi2Real nominal[],
                                             size_t nx) {
  gbInstance* c = (gbInstance*)component;
  size_t i;
  if (!gb_allowed(c, "fmi2GetNominalsOfContinuousStates",
                  gbInstantiated | gbEvent | gbContinuousTime | gbTerminated | gbError))
    return fmi2Error;
  if (nx != GB_N_STATES || !nominal) return fmi2Error;
  for (i = 0; i < nx; ++i) nominal[i] = 1.0;
  return fmi2OK;
}

/* ---- Co-Simulation: shared by the model's step and a virtual sensor's ---------------------- */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component component, const fmi2ValueReference vr[],
                                       size_t nvr, const fmi2Integer order[],
                                       const fmi2Real value[]) {
  gbInstance* c = (gbInstance*)component;
  size_t k;
  if (!gb_allowed(c, "fmi2SetRealInputDerivatives",
                  gbInstantiated | gbInitialization | gbStepComplete))
    return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] < GB_VR_INPUT || vr[k] >= GB_VR_OUTPUT || order[k] != 1) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2SetRealInputDerivatives: value reference %u order %d is not an input's first "
             "derivative",
             (unsigned)vr[k], (int)order[k]);
      return fmi2Error;
    }
    c->du[vr[k] - GB_VR_INPUT] = value[k];
  }
  return fmi2OK;
}

/* Whether fmi2DoStep may step from t0 by h in c's state; logs and refuses if not. */
static int gb_step_allowed(gbInstance* c, double t0, double h) {
  if (!gb_allowed(c, "fmi2DoStep", gbStepComplete)) return 0;
  if (!(h > 0.0)) {
    gb_log(c, fmi2Error, "logStatusError", "fmi2DoStep: the step size %g is not positive", h);
    return 0;
  }
  if (fabs(t0 - c->time) > 1e-9 * (1.0 + fabs(t0))) {
    gb_log(c, fmi2Error, "logStatusError",
           "fmi2DoStep: the communication point %g is not the FMU's time %g", t0, c->time);
    return 0;
  }
  return 1;
}

/* After a step of h: the FMU's time, and the inputs where their slopes took them. */
static void gb_step_done(gbInstance* c, double t0, double h) {
  int i;
  c->time = t0 + h;
  for (i = 0; i < GB_N_INPUTS; ++i) {
    c->u[i] += c->du[i] * h;
    c->du[i] = 0.0;
  }
}

#ifndef GB_VIRTUAL_SENSOR
/* ---- Co-Simulation: the model integrated by Dormand-Prince 5(4) under error control -------- */

/* f at (t, x) with the inputs held over the step (or ramped by their derivatives). */
static int gb_rhs(gbInstance* c, double t, const double* x, double* f) {
  double s[GB_N_SLOTS];
  int i;
  for (i = 0; i < GB_N_STATES; ++i) s[i] = x[i];
  for (i = 0; i < GB_N_INPUTS; ++i) s[GB_SLOT_INPUT + i] = c->u[i] + c->du[i] * (t - c->step_start);
  for (i = 0; i < GB_N_PARAMETERS; ++i) s[GB_SLOT_PARAMETER + i] = c->theta[i];
  s[GB_SLOT_TIME] = t;
  gb_drift(s, f);
  for (i = 0; i < GB_N_STATES; ++i)
    if (!isfinite(f[i])) return i + 1;
  return 0;
}

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  static const double a21 = 1.0 / 5, a31 = 3.0 / 40, a32 = 9.0 / 40, a41 = 44.0 / 45,
                      a42 = -56.0 / 15, a43 = 32.0 / 9, a51 = 19372.0 / 6561, a52 = -25360.0 / 2187,
                      a53 = 64448.0 / 6561, a54 = -212.0 / 729, a61 = 9017.0 / 3168,
                      a62 = -355.0 / 33, a63 = 46732.0 / 5247, a64 = 49.0 / 176,
                      a65 = -5103.0 / 18656, b1 = 35.0 / 384, b3 = 500.0 / 1113, b4 = 125.0 / 192,
                      b5 = -2187.0 / 6784, b6 = 11.0 / 84;
  static const double e1 = 35.0 / 384 - 5179.0 / 57600, e3 = 500.0 / 1113 - 7571.0 / 16695,
                      e4 = 125.0 / 192 - 393.0 / 640, e5 = -2187.0 / 6784 + 92097.0 / 339200,
                      e6 = 11.0 / 84 - 187.0 / 2100, e7 = -1.0 / 40;
  gbInstance* c = (gbInstance*)component;
  double k1[GB_N_STATES], k2[GB_N_STATES], k3[GB_N_STATES], k4[GB_N_STATES], k5[GB_N_STATES],
      k6[GB_N_STATES], k7[GB_N_STATES], y[GB_N_STATES], x_new[GB_N_STATES];
  const double t0 = currentCommunicationPoint, t1 = t0 + communicationStepSize;
  double t = t0, h;
  long attempts = 0;
  int i, bad;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (!gb_step_allowed(c, t0, communicationStepSize)) return fmi2Error;
  c->step_start = t0;
  h = c->h_hint > 0.0 && c->h_hint < communicationStepSize ? c->h_hint : communicationStepSize;
  if ((bad = gb_rhs(c, t, c->x, k1)) != 0) goto not_finite;
  while (t < t1) {
    double worst = 0.0;
    const int last = h >= t1 - t;
    if (last) h = t1 - t;
    if (++attempts > 1000000 || !(h > 1e-14 * communicationStepSize)) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: the integration from t = %g stalled at t = %g (step %g)", t0, t, h);
      c->state = gbError;
      return fmi2Error;
    }
    for (i = 0; i < GB_N_STATES; ++i) y[i] = c->x[i] + h * a21 * k1[i];
    bad = gb_rhs(c, t + h / 5, y, k2);
    for (i = 0; i < GB_N_STATES; ++i) y[i] = c->x[i] + h * (a31 * k1[i] + a32 * k2[i]);
    bad = bad ? bad : gb_rhs(c, t + 0.3 * h, y, k3);
    for (i = 0; i < GB_N_STATES; ++i)
      y[i] = c->x[i] + h * (a41 * k1[i] + a42 * k2[i] + a43 * k3[i]);
    bad = bad ? bad : gb_rhs(c, t + 0.8 * h, y, k4);
    for (i = 0; i < GB_N_STATES; ++i)
      y[i] = c->x[i] + h * (a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i]);
    bad = bad ? bad : gb_rhs(c, t + h * 8 / 9, y, k5);
    for (i = 0; i < GB_N_STATES; ++i)
      y[i] = c->x[i] + h * (a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i]);
    bad = bad ? bad : gb_rhs(c, t + h, y, k6);
    for (i = 0; i < GB_N_STATES; ++i)
      x_new[i] = c->x[i] + h * (b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i]);
    bad = bad ? bad : gb_rhs(c, t + h, x_new, k7);
    if (bad) { /* a stage left the model's domain: a shorter step */
      h *= 0.25;
      continue;
    }
    for (i = 0; i < GB_N_STATES; ++i) {
      const double err =
          h * (e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * k7[i]);
      const double scale = GB_ATOL + GB_RTOL * (fabs(c->x[i]) + fabs(h * k1[i]));
      const double r = fabs(err) / scale;
      if (r > worst) worst = r;
    }
    if (worst > 1.0) {
      double shrink = 0.9 * pow(worst, -1.0 / 3);
      h *= shrink > 0.2 ? shrink : 0.2;
      continue;
    }
    t = last ? t1 : t + h;
    for (i = 0; i < GB_N_STATES; ++i) {
      c->x[i] = x_new[i];
      k1[i] = k7[i];
    }
    if (worst < 0.5) h *= 0.9 * pow(worst > 3.2e-4 ? worst : 3.2e-4, -0.2);
    if (!last) c->h_hint = h;
  }
  gb_step_done(c, t0, communicationStepSize);
  return fmi2OK;
not_finite:
  gb_log(c, fmi2Error, "logStatusError", "fmi2DoStep: the drift of %s is not finite at t = %g",
         gb_state_name[bad - 1], t);
  c->state = gbError;
  return fmi2Error;
}

#endif

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr;
  (void)nvr;
  (void)order;
  (void)value;
  return gb_not_provided(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2CancelStep(fmi2Component c) { return gb_not_provided(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status* value) {
  (void)s;
  (void)value;
  return gb_not_provided(c, "fmi2GetStatus");
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real* value) {
  (void)s;
  (void)value;
  return gb_not_provided(c, "fmi2GetRealStatus");
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer* value) {
  (void)s;
  (void)value;
  return gb_not_provided(c, "fmi2GetIntegerStatus");
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean* value) {
  (void)s;
  (void)value;
  return gb_not_provided(c, "fmi2GetBooleanStatus");
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String* value) {
  (void)s;
  (void)value;
  return gb_not_provided(c, "fmi2GetStringStatus");
}
