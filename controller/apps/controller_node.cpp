#include "controller_node.hpp"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <exoid/lcm/channels.hpp>

namespace exoid::controller {
namespace {
constexpr size_t kEstimateBufferBytes = size_t{64} << 20;  // as exo_estimator's and exoid_logger's sockets
constexpr int kPollSliceMs = 50;  // longest single wait inside the loop (keeps signals responsive)
constexpr int kMaxReportedRejections = 5;
}  // namespace

ControllerNode::ControllerNode(LcmEndpoint& lcm, const Model& model, BalanceController& ctrl,
                               const ControllerConfig& config, bool use_estimate, int wait_estimate_ms)
    : lcm_(lcm),
      ctrl_(ctrl),
      config_(config),
      joint_names_(model.joint_names),
      param_names_(model.paramNames()),
      coord_names_(model.coordinateNames()),
      gate_({channels::kState, channels::kEstimate, channels::kPlateRight, channels::kPlateLeft}) {
  ch_state_ = gate_.channelIndex(channels::kState);
  ch_estimate_ = gate_.channelIndex(channels::kEstimate);
  ch_plate_[0] = gate_.channelIndex(channels::kPlateRight);
  ch_plate_[1] = gate_.channelIndex(channels::kPlateLeft);
  state_.q = Eigen::VectorXd::Zero(model.njoints);
  state_.tau = Eigen::VectorXd::Zero(model.njoints);
  state_.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model.njoints, true);
  bad_state_ = state_;
  held_state_ = state_;
  wait_estimate_ms_ = use_estimate ? wait_estimate_ms : 0;
  bad_state_.q.setConstant(std::nan(""));  // a sample the controller rejects: it answers with its fallback
  estimate_.params = Eigen::VectorXd::Zero(model.nparams());
  estimate_.param_stddev = Eigen::VectorXd::Zero(model.nparams());
  estimate_.tau_correction = Eigen::VectorXd::Zero(model.nv);
  estimate_.tau_correction_stddev = Eigen::VectorXd::Zero(model.nv);
  ctrl_.sizeCommand(command_);
  // Pre-size the outgoing messages once (toLcm reuses their vectors afterwards).
  toLcm(command_, joint_names_, command_msg_);
  toLcm(static_cast<const ControllerStatusSample&>(status_), status_msg_);
  lcm_.reserve(static_cast<size_t>(std::max(command_msg_.getEncodedSize(), status_msg_.getEncodedSize())) + 1024);
  lcm_.subscribeRaw(channels::kState, [this](const char*, const void* data, int size, int64_t) { onState(data, size); });
  if (usesForcePlates(config_)) {
    // The plates of tick k arrive after the state of tick k: the disturbance observer pairs them with the wrench it
    // planned for that tick, so they are used one tick later (by the CoM observer too).
    for (int i = 0; i < 2; ++i) {
      const char* channel = i == 0 ? channels::kPlateRight : channels::kPlateLeft;
      lcm_.subscribeRaw(channel, [this, i](const char*, const void* data, int size, int64_t) {
        if (!gate_.admitEncoded(ch_plate_[i], data, size, plate_msg_, plate_, nullptr, i)) return;
        if (!holding_) {
          ctrl_.setForcePlate(plate_);
          return;
        }
        if (plate_held_[i]) ctrl_.setForcePlate(held_plate_[i]);  // (not in lockstep: a newer one of this plate)
        held_plate_[i] = plate_;
        plate_held_[i] = true;
      });
    }
  }
  if (!use_estimate) return;
  if (lcm_.url().rfind("udpm://", 0) == 0) {
    std::string why;
    estimate_rx_ = lcmwire::UdpmReceiver::open(lcm_.url(), kEstimateBufferBytes, &why);
    if (estimate_rx_) {
      estimate_handler_ = [this](const std::string& channel, const uint8_t* data, size_t size, int64_t) {
        if (channel == channels::kEstimate) onEstimate(data, static_cast<int>(size));
      };
      return;
    }
    std::fprintf(stderr, "exo_controller: %s: own socket refused (%s): receiving it through LCM\n",
                 channels::kEstimate, why.c_str());
  }
  lcm_.subscribeRaw(channels::kEstimate,
                    [this](const char*, const void* data, int size, int64_t) { onEstimate(data, size); });
}

void ControllerNode::onEstimate(const void* data, int size) {
  // Every decoded estimate goes to the controller, which refuses (and counts) an unusable one.
  if (!gate_.admitEncoded(ch_estimate_, data, size, estimate_msg_, estimate_, nullptr, param_names_, kAnyNumBase,
                          coord_names_))
    return;
  ctrl_.setEstimate(estimate_);
  newest_estimate_tick_ = std::max(newest_estimate_tick_, estimate_.tick);
  if (holding_ && !mustWait(held_state_.tick)) answerHeld();
}

int ControllerNode::receive(int timeout_ms) {
  if (!estimate_rx_) return lcm_.handleTimeout(timeout_ms, &err_);
  pollfd pfd[2] = {{lcm_.fileno(), POLLIN, 0}, {estimate_rx_->fd(), POLLIN, 0}};
  if (::poll(pfd, 2, timeout_ms) < 0 && errno != EINTR) {
    err_ = "poll failed";
    return -1;
  }
  estimate_rx_->drain(estimate_handler_);  // the estimates first: a state held for one is answered at once
  return lcm_.handleAvailable(1000, &err_);
}

void ControllerNode::answer(const RobotStateSample& s) {
  ctrl_.tick(s, command_, status_);
  ++stats_.ticks;
  stats_.tick_sum += status_.tick_us;
  stats_.tick_max = std::max(stats_.tick_max, status_.tick_us);
  toLcm(command_, joint_names_, command_msg_);
  toLcm(static_cast<const ControllerStatusSample&>(status_), status_msg_);
  if (!lcm_.publish(channels::kCommand, command_msg_)) ++stats_.publish_errors;
  if (!lcm_.publish(channels::kControllerStatus, status_msg_)) ++stats_.publish_errors;
  if (status_.trajectory_ready && !status_.trajectory_done && status_.mode == CommandMode::Torque) {
    const double e = (status_.com_ref - status_.com).norm();
    stats_.se_com += e * e;
    stats_.max_com_err = std::max(stats_.max_com_err, e);
    ++stats_.com_samples;
  }
  if (status_.trajectory_ready && status_.trajectory_time >= ctrl_.trajectoryDuration() + config_.trajectory.final_hold)
    done_ = true;
  if (status_.trajectory_failed) done_ = true;
}

bool ControllerNode::mustWait(int64_t tick) const {
  const int64_t need = tick - config_.estimate.lag_ticks;
  return wait_estimate_ms_ > 0 && stats_.estimate_timeouts == 0 && need >= 0 && newest_estimate_tick_ < need;
}

void ControllerNode::answerHeld() {
  holding_ = false;
  stats_.estimate_wait_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - held_since_).count();
  answer(held_state_);
  for (int i = 0; i < 2; ++i)
    if (plate_held_[i]) ctrl_.setForcePlate(held_plate_[i]), plate_held_[i] = false;
}

void ControllerNode::checkWaitTimeout() {
  if (!holding_ || std::chrono::steady_clock::now() - held_since_ < std::chrono::milliseconds(wait_estimate_ms_))
    return;
  ++stats_.estimate_timeouts;
  stats_.estimate_wait_stopped_tick = held_state_.tick;
  std::fprintf(stderr,
               "exo_controller: no %s with tick >= %lld within %d ms at tick %lld (%s): answering without "
               "waiting from here; the run depends on scheduling\n",
               channels::kEstimate, static_cast<long long>(held_state_.tick - config_.estimate.lag_ticks),
               wait_estimate_ms_, static_cast<long long>(held_state_.tick),
               newest_estimate_tick_ < 0 ? "none received yet" : "the estimator stopped answering");
  answerHeld();
}

void ControllerNode::onState(const void* data, int size) {
  last_state_ = std::chrono::steady_clock::now();
  if (holding_) answerHeld();  // a newer state (not in lockstep, where the sim waits for the answer)
  std::string* why = reported_ < kMaxReportedRejections ? &err_ : nullptr;
  if (gate_.admitEncoded(ch_state_, data, size, state_msg_, state_, why, joint_names_)) {
    if (mustWait(state_.tick)) {  // lockstep: its estimate first
      held_state_ = state_;
      holding_ = true;
      held_since_ = std::chrono::steady_clock::now();
      ++stats_.estimate_waits;
      return;
    }
    answer(state_);
    return;
  }
  if (why) {
    std::fprintf(stderr, "exo_controller: rejected %s: %s\n", channels::kState, err_.c_str());
    ++reported_;
  }
  // A decodable state with a new tick that failed the checks gets the fallback answer; duplicates and
  // out-of-order states do not (the command for their tick was already sent).
  int64_t last = 0;
  const bool has_last = gate_.lastTick(ch_state_, &last);
  if (size > 0 && state_msg_.tick > (has_last ? last : -1) && state_msg_.tick >= 0) {
    bad_state_.tick = state_msg_.tick;
    bad_state_.utime = state_msg_.utime;
    answer(bad_state_);
    ++stats_.answered_bad;
  } else {
    ++stats_.unanswered;
  }
}

ControllerNode::Outcome ControllerNode::run(int64_t idle_timeout_ms, const volatile std::sig_atomic_t* stop) {
  while (!done_) {
    if (*stop) return Outcome::Interrupted;
    const auto idle =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - last_state_).count();
    if (idle >= idle_timeout_ms) {
      std::fprintf(stderr, "exo_controller: no %s for %lld ms, exiting\n", channels::kState, static_cast<long long>(idle));
      return Outcome::IdleTimeout;
    }
    checkWaitTimeout();
    const int wait = static_cast<int>(std::min<long long>(holding_ ? 1 : kPollSliceMs, idle_timeout_ms - idle));
    if (receive(std::max(wait, 1)) < 0) {
      std::fprintf(stderr, "exo_controller: LCM: %s\n", err_.c_str());
      return Outcome::LcmError;
    }
  }
  return Outcome::Done;
}

}  // namespace exoid::controller
