#include "plugin_link.hpp"

#include <time.h>

#include <algorithm>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::sim {
namespace {
int64_t threadCpuNs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return int64_t{ts.tv_sec} * 1000000000 + ts.tv_nsec;
}
}  // namespace

PluginLink::PluginLink(ControllerPlugin& plugin, LcmEndpoint& ep, const std::vector<std::string>& joint_names)
    : plugin_(plugin), ep_(ep), joint_names_(joint_names), gate_({channels::kEstimate}) {
  toLcm(plugin_.command(), joint_names_, command_msg_);  // sizes the outgoing messages once
  toLcm(plugin_.status(), status_msg_);
  ep_.reserve(static_cast<size_t>(std::max(command_msg_.getEncodedSize(), status_msg_.getEncodedSize())) + 1024);
  // EXO_ESTIMATE names the model's parameters: without the plugin's URDF there is nothing to check them against.
  Model model;
  if (plugin_.options().listen_estimate && !plugin_.options().model_path.empty() &&
      buildModelFromUrdfFile(plugin_.options().model_path, true, model, nullptr)) {
    param_names_ = model.paramNames();
    estimate_.params = Eigen::VectorXd::Zero(model.nparams());
    estimate_.param_stddev = Eigen::VectorXd::Zero(model.nparams());
    coord_names_ = model.coordinateNames();
    estimate_.tau_correction = Eigen::VectorXd::Zero(model.nv);
    subscription_ = ep_.subscribeRaw(channels::kEstimate, [this](const char*, const void* data, int size, int64_t) {
      if (gate_.admitEncoded(0, data, size, estimate_msg_, estimate_, nullptr, param_names_, kAnyNumBase,
                             coord_names_))
        plugin_.setEstimate(estimate_);  // every decoded estimate, as exo_controller: the plugin judges it
    });
  }
}

PluginLink::~PluginLink() {
  if (subscription_ > 0) ep_.unsubscribe(subscription_);
}

bool PluginLink::afterStep(const RobotStateSample& state, const ForcePlateSample* plates, CommandArbiter& arb,
                           std::string* err) {
  const int64_t cpu0 = threadCpuNs();
  const bool ran = plugin_.step(state);
  if (ran) call_cpu_ns_max_ = std::max(call_cpu_ns_max_, threadCpuNs() - cpu0);
  plugin_.setForcePlates(plates, EXOID_PLUGIN_NUM_PLATES);  // after the state, as exo_controller receives them
  arbiterOffer(arb, plugin_.command());
  if (!ran) return true;
  toLcm(plugin_.command(), joint_names_, command_msg_);
  bool ok = ep_.publish(channels::kCommand, command_msg_, err);
  if (plugin_.statusValid()) {
    toLcm(plugin_.status(), status_msg_);
    ok = ok && ep_.publish(channels::kControllerStatus, status_msg_, err);
  }
  return ok;
}

}  // namespace exoid::sim
