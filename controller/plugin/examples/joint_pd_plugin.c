/* libexoid_joint_pd_plugin.so: the smallest useful controller plugin (docs/plugin.md), in plain C.
 *
 * Joint-space PD that holds the standing pose: q0 is latched from the first state, then every tick
 *     tau_j = KP (q0_j - q_j) - KD dq_j,   |tau_j| <= TAU_MAX,
 * with dq the backward difference of the encoders over the actual tick gap. The host ignores the entries of
 * passive joints. No model, no configuration file: model_path and config_path are ignored. tick allocates
 * nothing and cannot fail once created; a state with a non-finite value is answered in DAMPING mode. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exoid/controller_plugin.h"

#define KP 1000.0     /* N m/rad: stiffer than the standing robot's gravity toppling (m g h ~ 400 N m/rad) */
#define KD 60.0      /* N m s/rad */
#define TAU_MAX 100.0 /* N m: the smallest actuator limit of the exoskeleton (ankles) */

typedef struct joint_pd {
  int32_t num_joints;
  double period_s;
  int has_q0;
  int64_t last_tick;
  double q0[EXOID_PLUGIN_MAX_JOINTS];
  double q_prev[EXOID_PLUGIN_MAX_JOINTS];
  exoid_plugin_status status;
} joint_pd;

static void pd_clear(joint_pd* p) {
  p->has_q0 = 0;
  p->last_tick = 0;
  memset(&p->status, 0, sizeof p->status);
  p->status.qp_status = 3; /* no QP */
  p->status.move_index = -1;
}

static void* pd_create(const exoid_plugin_config* c, char* error, size_t error_size) {
  if (!c || c->abi_version != EXOID_CONTROLLER_PLUGIN_ABI_VERSION) {
    snprintf(error, error_size, "joint PD plugin: host ABI version %u, plugin %u", c ? c->abi_version : 0u,
             EXOID_CONTROLLER_PLUGIN_ABI_VERSION);
    return NULL;
  }
  if (c->num_joints < 1 || c->num_joints > EXOID_PLUGIN_MAX_JOINTS || !(c->physics_period_s > 0.0) ||
      c->tick_divisor < 1) {
    snprintf(error, error_size, "joint PD plugin: %d joints (1..%d), period %g s, divisor %d", c->num_joints,
             EXOID_PLUGIN_MAX_JOINTS, c->physics_period_s, c->tick_divisor);
    return NULL;
  }
  joint_pd* p = (joint_pd*)calloc(1, sizeof(joint_pd));
  if (!p) {
    snprintf(error, error_size, "joint PD plugin: out of memory");
    return NULL;
  }
  p->num_joints = c->num_joints;
  p->period_s = c->physics_period_s;
  pd_clear(p);
  return p;
}

static int pd_reset(void* self) {
  pd_clear((joint_pd*)self);
  return EXOID_PLUGIN_OK;
}

static int pd_tick(void* self, const exoid_plugin_state* in, exoid_plugin_command* out) {
  joint_pd* p = (joint_pd*)self;
  const int n = p->num_joints;
  if (in->num_joints != n) return EXOID_PLUGIN_ERROR;
  int finite = 1;
  for (int j = 0; j < n; ++j) finite = finite && isfinite(in->q[j]);
  out->utime = in->utime;
  out->tick = in->tick + 1;
  out->source_tick = in->tick;
  out->num_joints = n;
  out->mode = finite ? EXOID_MODE_TORQUE : EXOID_MODE_DAMPING;
  p->status.utime = in->utime;
  p->status.tick = in->tick;
  if (!finite || (p->has_q0 && in->tick <= p->last_tick)) {
    p->status.rejected_inputs += 1;
    p->status.fallbacks += 1;
    if (finite) out->mode = EXOID_MODE_HOLD; /* out of order: keep the previous command */
    for (int j = 0; j < n; ++j) out->tau[j] = out->tau_ff[j] = 0.0;
    return EXOID_PLUGIN_OK;
  }
  if (!p->has_q0) {
    memcpy(p->q0, in->q, sizeof(double) * (size_t)n);
    memcpy(p->q_prev, in->q, sizeof(double) * (size_t)n);
    p->has_q0 = 1;
    p->last_tick = in->tick;
  }
  const int64_t gap = in->tick - p->last_tick;
  const double dt = p->period_s * (double)(gap > 0 ? gap : 1);
  for (int j = 0; j < n; ++j) {
    const double dq = gap > 0 ? (in->q[j] - p->q_prev[j]) / dt : 0.0;
    double tau = KP * (p->q0[j] - in->q[j]) - KD * dq;
    if (tau > TAU_MAX) tau = TAU_MAX;
    if (tau < -TAU_MAX) tau = -TAU_MAX;
    out->tau[j] = tau;
    out->tau_ff[j] = 0.0;
    p->q_prev[j] = in->q[j];
  }
  if (gap > 1) p->status.stale_inputs += (int32_t)(gap - 1);
  p->last_tick = in->tick;
  return EXOID_PLUGIN_OK;
}

static int pd_status(const void* self, exoid_plugin_status* out) {
  *out = ((const joint_pd*)self)->status;
  return EXOID_PLUGIN_OK;
}

static void pd_destroy(void* self) { free(self); }

static const exoid_controller_plugin_api kApi = {
    EXOID_CONTROLLER_PLUGIN_ABI_VERSION,
    sizeof(exoid_plugin_state),
    sizeof(exoid_plugin_command),
    sizeof(exoid_plugin_status),
    "joint PD holding the standing pose",
    pd_create,
    pd_reset,
    pd_tick,
    pd_status,
    NULL, /* no online estimate */
    pd_destroy,
    sizeof(exoid_plugin_force_plate),
    NULL, /* no force plates */
    sizeof(exoid_plugin_estimate),
};

__attribute__((visibility("default"))) const exoid_controller_plugin_api* exoid_controller_plugin(void) {
  return &kApi;
}
