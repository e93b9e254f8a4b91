/* A test plugin that misbehaves on purpose (test_controller_plugin). Its config_path is a fault script:
 *     "<kind> <from> <to> [microseconds]"
 * Ticks in [from, to) misbehave as <kind>: error (returns EXOID_PLUGIN_ERROR), nan (a NaN torque), bad_tick
 * (command stamped for the wrong tick), slow (busy-waits the given microseconds, then answers well),
 * create_fail (create fails, whatever the range), plates (set_force_plates returns EXOID_PLUGIN_ERROR for
 * the plates of those ticks; it also refuses a wrong count, plate order or tick). Every other tick answers
 * tau_j = j + 1 + tick * 1e-3.
 * Built also with EXOID_FAULT_ABI_VERSION (another ABI version: 1, a plugin from before the force plates) and EXOID_FAULT_STATE_SIZE (a state struct of
 * another size), as a plugin built against another header would be, and EXOID_FAULT_NO_ENTRY (a shared
 * library that is not a plugin). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "exoid/controller_plugin.h"

#ifndef EXOID_FAULT_ABI_VERSION
#define EXOID_FAULT_ABI_VERSION EXOID_CONTROLLER_PLUGIN_ABI_VERSION
#endif
#ifndef EXOID_FAULT_STATE_SIZE
#define EXOID_FAULT_STATE_SIZE sizeof(exoid_plugin_state)
#endif

typedef struct fault {
  char kind[32];
  long long from, to;
  double us;
  int nj;
  exoid_plugin_status status;
} fault;

static void* f_create(const exoid_plugin_config* c, char* error, size_t size) {
  fault* f = (fault*)calloc(1, sizeof(fault));
  if (!f) return NULL;
  f->kind[0] = '\0';
  if (!c->config_path || sscanf(c->config_path, "%31s %lld %lld %lf", f->kind, &f->from, &f->to, &f->us) < 3 ||
      strcmp(f->kind, "create_fail") == 0) {
    snprintf(error, size, "fault plugin: script '%s' says fail", c->config_path ? c->config_path : "");
    free(f);
    return NULL;
  }
  f->nj = c->num_joints;
  f->status.qp_status = 3;
  f->status.move_index = -1;
  return f;
}

static int f_reset(void* self) { return EXOID_PLUGIN_OK; }

static double nowUs(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec * 1e6 + (double)ts.tv_nsec * 1e-3;
}

static int f_tick(void* self, const exoid_plugin_state* in, exoid_plugin_command* out) {
  fault* f = (fault*)self;
  const int bad = in->tick >= f->from && in->tick < f->to;
  out->utime = in->utime;
  out->tick = in->tick + 1;
  out->source_tick = in->tick;
  out->mode = EXOID_MODE_TORQUE;
  out->num_joints = f->nj;
  for (int j = 0; j < f->nj; ++j) {
    out->tau[j] = j + 1 + (double)in->tick * 1e-3;
    out->tau_ff[j] = 0.0;
  }
  f->status.tick = in->tick;
  f->status.utime = in->utime;
  if (!bad) return EXOID_PLUGIN_OK;
  if (strcmp(f->kind, "error") == 0) return EXOID_PLUGIN_ERROR;
  if (strcmp(f->kind, "nan") == 0) out->tau[f->nj - 1] = NAN;
  if (strcmp(f->kind, "bad_tick") == 0) out->tick = in->tick;
  if (strcmp(f->kind, "slow") == 0) {
    const double t0 = nowUs();
    while (nowUs() - t0 < f->us) {
    }
  }
  return EXOID_PLUGIN_OK;
}

static int f_status(const void* self, exoid_plugin_status* out) {
  *out = ((const fault*)self)->status;
  return EXOID_PLUGIN_OK;
}

static int f_set_force_plates(void* self, const exoid_plugin_force_plate* plates, int32_t n) {
  fault* f = (fault*)self;
  if (!plates || n != EXOID_PLUGIN_NUM_PLATES || plates[0].plate != 0 || plates[1].plate != 1 ||
      plates[0].tick != plates[1].tick)
    return EXOID_PLUGIN_ERROR;
  const int bad = plates[0].tick >= f->from && plates[0].tick < f->to;
  return bad && strcmp(f->kind, "plates") == 0 ? EXOID_PLUGIN_ERROR : EXOID_PLUGIN_OK;
}

static void f_destroy(void* self) { free(self); }

static const exoid_controller_plugin_api kApi __attribute__((used)) = {
    EXOID_FAULT_ABI_VERSION, EXOID_FAULT_STATE_SIZE, sizeof(exoid_plugin_command), sizeof(exoid_plugin_status),
    "fault injection", f_create, f_reset, f_tick, f_status, NULL, f_destroy, sizeof(exoid_plugin_force_plate),
    f_set_force_plates, sizeof(exoid_plugin_estimate),
};

#ifndef EXOID_FAULT_NO_ENTRY
__attribute__((visibility("default"))) const exoid_controller_plugin_api* exoid_controller_plugin(void) {
  return &kApi;
}
#endif
