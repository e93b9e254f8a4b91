#include "plugin_link.hpp"

#include <algorithm>
#include <cstdio>

#include "exoid/common/clock.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::sim {
namespace {
constexpr size_t kRawBufferBytes = size_t{64} << 20;  // the estimator's and the logger's: bursts wait there
using common::threadCpuNs;
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
    estimate_.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
    if (ep_.url().rfind("udpm://", 0) == 0) {
      std::string why;
      receiver_ = lcmwire::UdpmReceiver::open(ep_.url(), kRawBufferBytes, &why);
      if (receiver_) {
        raw_handler_ = [this](const std::string& channel, const uint8_t* data, size_t size, int64_t) {
          if (channel == channels::kEstimate) onEstimate(data, static_cast<int>(size));
        };
        return;
      }
      std::fprintf(stderr, "exo_sim: %s: own socket refused (%s): receiving it through LCM\n", channels::kEstimate,
                   why.c_str());
    }
    subscription_ = ep_.subscribeRaw(channels::kEstimate, [this](const char*, const void* data, int size, int64_t) {
      onEstimate(data, size);
    });
  }
}

void PluginLink::onEstimate(const void* data, int size) {
  if (!gate_.admitEncoded(0, data, size, estimate_msg_, estimate_, nullptr, param_names_, kAnyNumBase, coord_names_))
    return;
  plugin_.setEstimate(estimate_);  // every decoded estimate, as exo_controller: the plugin judges it
  newest_estimate_tick_ = std::max(newest_estimate_tick_, estimate_.tick);
}

bool PluginLink::drain(std::string* err) {
  if (!receiver_ || receiver_->drain(raw_handler_) >= 0) return true;
  if (err) *err = "EXO_ESTIMATE: receive failed";
  return false;
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
