// libexoid_controller_plugin.so: the centroidal balance controller (BalanceController, docs/controller.md)
// behind the controller plugin C ABI (interfaces/include/exoid/controller_plugin.h, docs/plugin.md).
// Wraps the controller through its public API only; the conversions copy doubles, so the plugin computes
// bit-for-bit what exo_controller computes from the same states.
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

#include "exoid/controller/balance_controller.hpp"
#include "exoid/controller_plugin.h"
#include "exoid/controller_plugin_samples.hpp"
#include "exoid/model/urdf.hpp"

namespace {

using exoid::controller::BalanceController;
using exoid::controller::ControllerConfig;
using exoid::controller::ControllerStatus;

struct BalancePlugin {
  exoid::Model model;
  ControllerConfig cfg;
  uint64_t seed = 1;
  std::unique_ptr<BalanceController> ctrl;
  exoid::RobotStateSample state;       // [nj] sized at create
  exoid::JointCommandSample command;   // [nj]
  ControllerStatus status;
  exoid::EstimatorOutputSample estimate;  // params [nparams], tau_correction [nv], sized at create
  exoid::ForcePlateSample plate;
  double finished_after_s = 0.0;       // trajectory time at which the task is over (moves + final hold)
};

void writeError(char* error, size_t size, const std::string& text) {
  if (error && size > 0) std::snprintf(error, size, "%s", text.c_str());
}

// Builds the controller (allocates): create and reset.
bool build(BalancePlugin& p, std::string* err) {
  p.ctrl = std::make_unique<BalanceController>(p.model, p.cfg, p.seed);
  if (!p.ctrl->ok()) return *err = p.ctrl->error(), false;
  p.ctrl->sizeCommand(p.command);
  p.status = ControllerStatus{};
  return true;
}

void* create(const exoid_plugin_config* c, char* error, size_t error_size) {
  try {
    if (!c) return writeError(error, error_size, "no configuration"), nullptr;
    if (c->abi_version != EXOID_CONTROLLER_PLUGIN_ABI_VERSION)
      return writeError(error, error_size, "host ABI version " + std::to_string(c->abi_version) + ", plugin " +
                                               std::to_string(EXOID_CONTROLLER_PLUGIN_ABI_VERSION)),
             nullptr;
    auto p = std::make_unique<BalancePlugin>();
    std::string err;
    const std::string model_path = c->model_path ? c->model_path : "";
    const std::string config_path = c->config_path ? c->config_path : "";
    if (!exoid::buildModelFromUrdfFile(model_path, true, p->model, &err))
      return writeError(error, error_size, "model '" + model_path + "': " + err), nullptr;
    if (!exoid::controller::loadControllerConfig(config_path, p->cfg, &err))
      return writeError(error, error_size, err), nullptr;
    if (c->moves < 0 || c->moves > 1000)
      return writeError(error, error_size, "moves: expected 0..1000, got " + std::to_string(c->moves)), nullptr;
    if (c->moves > 0) p->cfg.trajectory.moves = c->moves;
    if (!(c->physics_period_s > 0.0) || std::abs(c->physics_period_s - p->cfg.loop.period) > 1e-12)
      return writeError(error, error_size, config_path + ": loop.period " + std::to_string(p->cfg.loop.period) +
                                               " s differs from the host's physics period " +
                                               std::to_string(c->physics_period_s) + " s"),
             nullptr;
    // The controller counts a state more than max_missed_ticks after the previous one as stale.
    if (c->tick_divisor < 1 || c->tick_divisor - 1 > p->cfg.fallback.max_missed_ticks)
      return writeError(error, error_size, "tick divisor " + std::to_string(c->tick_divisor) +
                                               ": the balance controller needs 1.." +
                                               std::to_string(p->cfg.fallback.max_missed_ticks + 1) +
                                               " (fallback.max_missed_ticks + 1)"),
             nullptr;
    if (c->num_joints != p->model.njoints || c->num_joints > EXOID_PLUGIN_MAX_JOINTS || !c->joint_names)
      return writeError(error, error_size, "host has " + std::to_string(c->num_joints) + " joints, model '" +
                                               model_path + "' " + std::to_string(p->model.njoints)),
             nullptr;
    for (int j = 0; j < c->num_joints; ++j) {
      const char* name = c->joint_names[j] ? c->joint_names[j] : "";
      if (p->model.joint_names[static_cast<size_t>(j)] != name)
        return writeError(error, error_size, "joint " + std::to_string(j) + ": host '" + name + "', model '" +
                                                 p->model.joint_names[static_cast<size_t>(j)] + "'"),
               nullptr;
    }
    p->seed = c->seed;
    const int nj = p->model.njoints;
    p->state.q = Eigen::VectorXd::Zero(nj);
    p->state.tau = Eigen::VectorXd::Zero(nj);
    p->state.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(nj, false);
    p->estimate.params = Eigen::VectorXd::Zero(p->model.nparams());
    p->estimate.tau_correction = Eigen::VectorXd::Zero(p->model.nv);
    p->estimate.tau_correction_stddev = Eigen::VectorXd::Zero(p->model.nv);
    if (!build(*p, &err)) return writeError(error, error_size, config_path + ": " + err), nullptr;
    return p.release();
  } catch (const std::exception& e) {
    writeError(error, error_size, std::string("balance plugin: ") + e.what());
  } catch (...) {
    writeError(error, error_size, "balance plugin: unknown exception");
  }
  return nullptr;
}

int reset(void* self) {
  try {
    auto& p = *static_cast<BalancePlugin*>(self);
    std::string err;
    return build(p, &err) ? EXOID_PLUGIN_OK : EXOID_PLUGIN_ERROR;
  } catch (...) {
    return EXOID_PLUGIN_ERROR;
  }
}

// Allocation-free: copies into the pre-sized samples, ticks, copies out.
int tick(void* self, const exoid_plugin_state* in, exoid_plugin_command* out) noexcept {
  auto& p = *static_cast<BalancePlugin*>(self);
  const int nj = p.model.njoints;
  if (!in || !out || in->num_joints != nj || !exoid::plugin_abi::fromPlugin(*in, p.state)) return EXOID_PLUGIN_ERROR;
  p.ctrl->tick(p.state, p.command, p.status);
  if (!exoid::plugin_abi::toPlugin(p.command, *out)) return EXOID_PLUGIN_ERROR;
  if (p.status.trajectory_ready && p.finished_after_s == 0.0)
    p.finished_after_s = p.ctrl->trajectoryDuration() + p.cfg.trajectory.final_hold;
  return EXOID_PLUGIN_OK;
}

int status(const void* self, exoid_plugin_status* out) noexcept {
  const auto& p = *static_cast<const BalancePlugin*>(self);
  if (!out) return EXOID_PLUGIN_ERROR;
  const ControllerStatus& s = p.status;
  exoid::plugin_abi::toPlugin(s, *out);
  // exo_controller's exit condition (the trajectory failing to generate also ends the task).
  out->finished = s.trajectory_failed || (s.trajectory_ready && p.finished_after_s > 0.0 &&
                                          s.trajectory_time >= p.finished_after_s);
  return EXOID_PLUGIN_OK;
}

// exo_controller's EXO_ESTIMATE handler: every estimate to BalanceController::setEstimate, which judges it.
int setEstimate(void* self, const exoid_plugin_estimate* e) noexcept {
  auto& p = *static_cast<BalancePlugin*>(self);
  if (!e || !exoid::plugin_abi::fromPlugin(*e, p.estimate)) return EXOID_PLUGIN_ERROR;
  return p.ctrl->setEstimate(p.estimate) ? EXOID_PLUGIN_OK : EXOID_PLUGIN_ERROR;
}

// exo_controller's EXO_PLATE_RIGHT/LEFT handlers: subscribed only when the observer uses the plates, each sample
// checked and converted as fromLcm does, then setForcePlate. The host calls this after the tick of the plates'
// tick, the order in which exo_controller receives them.
int setForcePlates(void* self, const exoid_plugin_force_plate* plates, int32_t n) noexcept {
  auto& p = *static_cast<BalancePlugin*>(self);
  if (!plates || n != EXOID_PLUGIN_NUM_PLATES) return EXOID_PLUGIN_ERROR;
  if (!exoid::controller::usesForcePlates(p.cfg)) return EXOID_PLUGIN_OK;  // not listening
  bool ok = true;
  for (int i = 0; i < n; ++i)
    ok = exoid::plugin_abi::fromPlugin(plates[i], i, p.plate) && p.ctrl->setForcePlate(p.plate) && ok;
  return ok ? EXOID_PLUGIN_OK : EXOID_PLUGIN_ERROR;
}

void destroy(void* self) { delete static_cast<BalancePlugin*>(self); }

const exoid_controller_plugin_api kApi = {
    EXOID_CONTROLLER_PLUGIN_ABI_VERSION,
    sizeof(exoid_plugin_state),
    sizeof(exoid_plugin_command),
    sizeof(exoid_plugin_status),
    "exoid centroidal balance controller",
    create,
    reset,
    tick,
    status,
    setEstimate,
    destroy,
    sizeof(exoid_plugin_force_plate),
    setForcePlates,
    sizeof(exoid_plugin_estimate),
};

}  // namespace

extern "C" __attribute__((visibility("default"))) const exoid_controller_plugin_api* exoid_controller_plugin(void) {
  return &kApi;
}
