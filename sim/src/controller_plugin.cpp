// Host side of the controller plugin ABI: dlopen, ABI checks, the loop stage with its counted fallback.
#include "exoid/sim/controller_plugin.hpp"

#include <dlfcn.h>
#include <time.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>

#include "exoid/controller_plugin_samples.hpp"

namespace exoid::sim {
namespace {

int64_t monoNs() {
  timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1000000000 + ts.tv_nsec;
}

bool allFinite(const double* v, int n) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(v[i])) return false;
  return true;
}

// The ABI checks of a plugin's function table: "" when it fits this host, else what is wrong (one line).
std::string apiMismatch(const exoid_controller_plugin_api* a) {
  if (!a) return std::string(EXOID_CONTROLLER_PLUGIN_ENTRY) + "() returned NULL";
  if (a->abi_version != EXOID_CONTROLLER_PLUGIN_ABI_VERSION)
    return "ABI version " + std::to_string(a->abi_version) + ", this exo_sim needs " +
           std::to_string(EXOID_CONTROLLER_PLUGIN_ABI_VERSION) + " (rebuild the plugin against controller_plugin.h)";
  if (a->state_size != sizeof(exoid_plugin_state) || a->command_size != sizeof(exoid_plugin_command) ||
      a->status_size != sizeof(exoid_plugin_status) || a->force_plate_size != sizeof(exoid_plugin_force_plate) ||
      a->estimate_size != sizeof(exoid_plugin_estimate))
    return "struct sizes (state " + std::to_string(a->state_size) + ", command " + std::to_string(a->command_size) +
           ", status " + std::to_string(a->status_size) + ", force plate " + std::to_string(a->force_plate_size) +
           ", estimate " + std::to_string(a->estimate_size) + ") differ from this exo_sim's (" +
           std::to_string(sizeof(exoid_plugin_state)) + ", " + std::to_string(sizeof(exoid_plugin_command)) + ", " +
           std::to_string(sizeof(exoid_plugin_status)) + ", " + std::to_string(sizeof(exoid_plugin_force_plate)) +
           ", " + std::to_string(sizeof(exoid_plugin_estimate)) + "): built against another controller_plugin.h";
  if (!a->create || !a->reset || !a->tick || !a->status || !a->destroy)
    return "the function table lacks create, reset, tick, status or destroy";
  return "";
}

// A status the runner may publish: every field in the range readers accept (fromLcm(controller_status_t)).
bool statusInRange(const exoid_plugin_status& st) {
  return st.qp_status >= 0 && st.qp_status <= 3 && st.qp_iterations >= 0 && st.move_index >= -1 &&
         st.moves_done >= 0 && st.fallbacks >= 0 && st.rejected_inputs >= 0 && st.stale_inputs >= 0 &&
         std::isfinite(st.qp_solve_us) && st.qp_solve_us >= 0.0 && std::isfinite(st.tick_us) && st.tick_us >= 0.0 &&
         allFinite(st.com_ref, 3) && allFinite(st.com, 3) && allFinite(st.com_vel_ref, 3) &&
         allFinite(st.com_vel, 3) && allFinite(st.momentum_rate_ref, 6) && allFinite(st.momentum, 6) &&
         allFinite(st.wrench_right, 6) && allFinite(st.wrench_left, 6);
}

}  // namespace

std::unique_ptr<ControllerPlugin> ControllerPlugin::load(const PluginOptions& o,
                                                         const std::vector<std::string>& joint_names,
                                                         double period_s, std::string* err) {
  auto fail = [&](const std::string& what) {
    if (err) *err = "--controller-plugin " + o.path + ": " + what;
    return nullptr;
  };
  if (o.divisor < 1) return fail("controller rate divisor must be >= 1, got " + std::to_string(o.divisor));
  if (joint_names.empty() || joint_names.size() > EXOID_PLUGIN_MAX_JOINTS)
    return fail("the robot has " + std::to_string(joint_names.size()) + " joints; the ABI carries 1.." +
                std::to_string(EXOID_PLUGIN_MAX_JOINTS));
  std::unique_ptr<ControllerPlugin> p(new ControllerPlugin);
  p->opt_ = o;
  p->nj_ = static_cast<int>(joint_names.size());
  std::string what;
  if (!p->open(&what) || !p->create(joint_names, period_s, &what)) return fail(what);
  p->command_.tau = Eigen::VectorXd::Zero(p->nj_);
  p->command_.tau_ff = Eigen::VectorXd::Zero(p->nj_);
  p->last_good_ = p->command_;
  if (!p->reset(err)) return nullptr;
  return p;
}

bool ControllerPlugin::open(std::string* what) {
  // A path without a slash would be searched in the library path: make it relative to the working directory.
  const std::string path = opt_.path.find('/') == std::string::npos ? "./" + opt_.path : opt_.path;
  dlerror();
  lib_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!lib_) {
    const char* e = dlerror();
    *what = std::string("cannot load: ") + (e ? e : "dlopen failed");
    return false;
  }
  auto entry = reinterpret_cast<exoid_controller_plugin_entry_fn>(dlsym(lib_, EXOID_CONTROLLER_PLUGIN_ENTRY));
  if (!entry) {
    *what = std::string("not a controller plugin: no symbol '") + EXOID_CONTROLLER_PLUGIN_ENTRY + "'";
    return false;
  }
  api_ = entry();
  *what = apiMismatch(api_);
  if (!what->empty()) api_ = nullptr;  // not this host's table: never called (nor its destroy)
  return what->empty();
}

bool ControllerPlugin::create(const std::vector<std::string>& joint_names, double period_s, std::string* what) {
  std::vector<const char*> names;
  for (const std::string& n : joint_names) names.push_back(n.c_str());
  exoid_plugin_config c{};
  c.abi_version = EXOID_CONTROLLER_PLUGIN_ABI_VERSION;
  c.num_joints = nj_;
  c.joint_names = names.data();
  c.model_path = opt_.model_path.c_str();
  c.config_path = opt_.config_path.c_str();
  c.seed = opt_.seed;
  c.moves = opt_.moves;
  c.tick_divisor = opt_.divisor;
  c.physics_period_s = period_s;
  char error[1024] = "";
  self_ = api_->create(&c, error, sizeof error);
  if (!self_) *what = std::string("create failed: ") + (error[0] ? error : "no reason given");
  return self_ != nullptr;
}

ControllerPlugin::~ControllerPlugin() {
  if (self_ && api_) api_->destroy(self_);
  if (lib_) dlclose(lib_);
}

const char* ControllerPlugin::name() const { return api_ && api_->name ? api_->name : "?"; }

bool ControllerPlugin::reset(std::string* err) {
  if (api_->reset(self_) != EXOID_PLUGIN_OK) {
    if (err) *err = "--controller-plugin " + opt_.path + ": reset failed";
    return false;
  }
  command_.tick = command_.source_tick = command_.utime = 0;
  command_.mode = CommandMode::Torque;
  command_.tau.setZero();
  command_.tau_ff.setZero();
  last_good_ = command_;
  has_good_ = false;
  bad_streak_ = 0;
  status_ = ControllerStatusSample{};
  status_valid_ = finished_ = false;
  stats_ = PluginStats{};
  return true;
}

void ControllerPlugin::fallback(int64_t k) {
  ++bad_streak_;
  command_.tick = k + 1;
  command_.source_tick = k;
  command_.tau_ff.setZero();
  if (has_good_ && bad_streak_ <= opt_.hold_ticks) {
    command_.mode = CommandMode::HoldLastSafe;  // the simulator re-applies its previous torque
    command_.tau = last_good_.tau;
    ++stats_.hold_ticks;
  } else {
    command_.mode = CommandMode::Damping;  // the simulator's drive damping
    command_.tau.setZero();
    ++stats_.damping_ticks;
  }
}

bool ControllerPlugin::step(const RobotStateSample& s) {
  const int64_t k = s.tick;
  if (k % opt_.divisor != 0) {  // zero-order hold between controller ticks
    command_.tick = k + 1;
    return false;
  }
  if (tickPlugin(s)) {
    acceptCommand();
  } else {
    fallback(k);
    command_.utime = s.utime;
  }
  readStatus(s.utime, k);
  return true;
}

bool ControllerPlugin::tickPlugin(const RobotStateSample& s) {
  const int64_t k = s.tick;
  if (!plugin_abi::toPlugin(s, in_) || in_.num_joints != nj_) {  // a host bug (the sim sizes its samples)
    ++stats_.failed;
    return false;
  }
  out_.num_joints = nj_;
  out_.tick = out_.source_tick = -1;  // the plugin must stamp them

  const int64_t t0 = monoNs();
  const int rc = api_->tick(self_, &in_, &out_);
  const double us = static_cast<double>(monoNs() - t0) * 1e-3;
  ++stats_.calls;
  stats_.call_us_sum += us;
  if (us > stats_.call_us_max) stats_.call_us_max = us;
  const bool overrun = opt_.budget_us > 0.0 && us > opt_.budget_us;
  if (overrun) ++stats_.overruns;

  if (rc != EXOID_PLUGIN_OK) {
    ++stats_.failed;
  } else if (out_.num_joints != nj_ || out_.tick != k + 1 || out_.source_tick != k || out_.mode < 0 ||
             out_.mode > EXOID_MODE_OFF) {
    ++stats_.bad_output;
  } else if (!allFinite(out_.tau, nj_) || !allFinite(out_.tau_ff, nj_)) {
    ++stats_.non_finite;
  } else {
    return !overrun;
  }
  return false;
}

void ControllerPlugin::acceptCommand() {
  ++stats_.good;
  bad_streak_ = 0;
  plugin_abi::fromPlugin(out_, command_);  // sizes checked in tickPlugin
  if (command_.mode == CommandMode::Torque) {
    last_good_ = command_;  // same sizes: no allocation
    has_good_ = true;
  }
}

void ControllerPlugin::readStatus(int64_t utime, int64_t k) {
  // Published only when every field is in range (readers reject the rest).
  status_valid_ = api_->status(self_, &st_) == EXOID_PLUGIN_OK && statusInRange(st_);
  if (!status_valid_) {
    ++stats_.bad_status;
    return;
  }
  plugin_abi::fromPlugin(st_, status_);
  status_.utime = utime;
  status_.tick = k;
  status_.fallbacks = st_.fallbacks + static_cast<int32_t>(stats_.fallbackTicks());
  finished_ = st_.finished != 0;
}

bool ControllerPlugin::setEstimate(const EstimatorOutputSample& estimate) {
  if (!api_->set_estimate) return false;  // the plugin does not use it: nothing to count
  exoid_plugin_estimate e{};
  plugin_abi::toPlugin(estimate, e);
  const bool ok = api_->set_estimate(self_, &e) == EXOID_PLUGIN_OK;
  ++(ok ? stats_.estimates_accepted : stats_.estimates_rejected);
  return ok;
}

bool ControllerPlugin::setForcePlates(const ForcePlateSample* plates, int num_plates) {
  if (!api_->set_force_plates) return false;  // the plugin does not use them: nothing to count
  bool ok = plates && num_plates == EXOID_PLUGIN_NUM_PLATES;
  for (int i = 0; ok && i < num_plates; ++i) plugin_abi::toPlugin(plates[i], plates_[i]);
  ok = ok && api_->set_force_plates(self_, plates_, num_plates) == EXOID_PLUGIN_OK;
  ++(ok ? stats_.plates_accepted : stats_.plates_rejected);
  return ok;
}

std::string ControllerPlugin::formatStats() const {
  const PluginStats& s = stats_;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "exo_sim: plugin '%s': calls %" PRId64 ", good %" PRId64 ", failed %" PRId64 ", non_finite %" PRId64
                ", bad_output %" PRId64 ", overruns %" PRId64 " (budget %.0f us), fallback ticks %" PRId64
                " (held %" PRId64 ", damping %" PRId64 "), bad status %" PRId64 ", estimates accepted %" PRId64
                " rejected %" PRId64 ", plates accepted %" PRId64 " rejected %" PRId64 ", call mean %.1f us max %.1f us",
                name(), s.calls, s.good, s.failed, s.non_finite, s.bad_output, s.overruns, opt_.budget_us,
                s.fallbackTicks(), s.hold_ticks, s.damping_ticks, s.bad_status, s.estimates_accepted,
                s.estimates_rejected, s.plates_accepted, s.plates_rejected, s.calls > 0 ? s.call_us_sum / static_cast<double>(s.calls) : 0.0,
                s.call_us_max);
  return buf;
}

}  // namespace exoid::sim
