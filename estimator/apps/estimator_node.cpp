#include "estimator_node.hpp"

#include <exoid/lcm/channels.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <algorithm>
#include <filesystem>

namespace exoid::estimator {

namespace {
// Datagrams handled per poll() on the raw socket (~0.1 s of a lockstep run's traffic): the caller's loop still
// turns (checkpoints, the stop signal) when the sim outpaces the estimator; the kernel buffer keeps the rest.
constexpr long kMaxDatagramsPerPoll = 4096;
constexpr int kPollSliceMs = 50;  // longest single wait inside run() (keeps signals responsive)
}  // namespace

EstimatorNode::EstimatorNode(LcmEndpoint& lcm, const Model& model, OnlineEstimator& estimator,
                             const NodeOptions& options)
    : lcm_(lcm),
      model_(model),
      est_(estimator),
      opt_(options),
      gate_({channels::kState, channels::kPlateRight, channels::kPlateLeft}),
      joint_names_(model.joint_names),
      param_names_(model.paramNames()),
      coord_names_(model.coordinateNames()) {
  ch_state_ = gate_.channelIndex(channels::kState);
  ch_plate_[0] = gate_.channelIndex(channels::kPlateRight);
  ch_plate_[1] = gate_.channelIndex(channels::kPlateLeft);
  state_.q = state_.tau = Eigen::VectorXd::Zero(model.njoints);
  state_.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(model.njoints, true);
  est_.sizeOutput(out_);
  toLcm(out_, param_names_, coord_names_, out_msg_);  // sizes the message once
  lcm_.reserve(static_cast<size_t>(out_msg_.getEncodedSize()) + 1024);
  last_checkpoint_ = last_state_ = std::chrono::steady_clock::now();
  if (opt_.raw_udpm && lcm_.url().rfind("udpm://", 0) == 0) {
    receiver_ = lcmwire::UdpmReceiver::open(lcm_.url(), opt_.recv_buffer_bytes, &error_);
    if (!receiver_) return;
    // Every channel of the group arrives here (commands, truth, our own estimates): only ours are decoded.
    raw_handler_ = [this](const std::string& channel, const uint8_t* data, size_t size, int64_t) {
      const int n = static_cast<int>(size);
      if (channel == channels::kState) onState(data, n);
      else if (channel == channels::kPlateRight) onPlate(0, data, n);
      else if (channel == channels::kPlateLeft) onPlate(1, data, n);
    };
    return;
  }
  lcm_.subscribeRaw(channels::kState,
                    [this](const char*, const void* data, int size, int64_t) { onState(data, size); });
  for (int i = 0; i < 2; ++i)
    lcm_.subscribeRaw(i == 0 ? channels::kPlateRight : channels::kPlateLeft,
                      [this, i](const char*, const void* data, int size, int64_t) { onPlate(i, data, size); });
}

void EstimatorNode::onState(const void* data, int size) {
  last_state_ = std::chrono::steady_clock::now();
  if (gate_.admitEncoded(ch_state_, data, size, state_msg_, state_, nullptr, joint_names_)) {
    est_.addState(state_);
    maybePublish();
  }
}

void EstimatorNode::onPlate(int i, const void* data, int size) {
  if (gate_.admitEncoded(ch_plate_[i], data, size, plate_msg_, plate_, nullptr, i)) {
    est_.addPlate(plate_);
    maybePublish();
  }
}

void EstimatorNode::maybePublish() {
  // Tick-aligned, so that the publications are a function of the rows folded in: the first row at or after each
  // row r with (r + 1) % publish_every == 0 (after a gap, the first row past it).
  if (est_.samplesSincePublication() == 0) return;
  const long row = est_.lastRowTick(), n = opt_.publish_every;
  if (next_row_ < 0) next_row_ = (row + n) / n * n - 1;  // the first aligned row >= the first row
  if (row < next_row_) return;
  next_row_ = (row + 1 + n) / n * n - 1;  // the next aligned row after this one
  publish();
}

void EstimatorNode::cycleReconcile() {
  const int j = next_job_;  // the oldest job in flight
  next_job_ = (next_job_ + 1) % kReconcileDepth;
  std::future<void>& pending = pending_[static_cast<size_t>(j)];
  OnlineEstimator::ReconcileJob& job = jobs_[static_cast<size_t>(j)];
  if (pending.valid()) {
    if (pending.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
      const auto t0 = std::chrono::steady_clock::now();
      pending.wait();
      ++reconcile_waits_;
      const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      reconcile_wait_s_ += waited;
      reconcile_wait_max_s_ = std::max(reconcile_wait_max_s_, waited);
    }
    pending.get();
  }
  if (job_begun_[static_cast<size_t>(j)]) est_.finishReconcile(job);  // phi_c from the next publication on
  job_begun_[static_cast<size_t>(j)] = est_.beginReconcile(job);
  if (!job_begun_[static_cast<size_t>(j)]) return;
  if (opt_.reconcile_async) pending = std::async(std::launch::async, [this, &job] { est_.solveReconcile(job); });
  else est_.solveReconcile(job);
}

void EstimatorNode::publish() {
  est_.fillOutput(out_);
  // Consistent standard parameters at a lower rate (allocates, ~10 ms: docs/estimator.md), off the receive
  // path: begun at one due publication, adopted at the next whatever the worker's timing.
  if (est_.reconcileDue()) cycleReconcile();
  out_.utime = out_.tick * 1000;  // the simulated (or hardware) time of the tick the estimate reached
  // Messages the gate refused never reached the estimator: their counts join the estimator's own.
  out_.rejected_nonfinite += static_cast<int32_t>(gate_.rejected(RejectReason::NonFinite) +
                                                  gate_.rejected(RejectReason::Malformed));
  out_.rejected_out_of_order += static_cast<int32_t>(gate_.rejected(RejectReason::OutOfOrder));
  out_.rejected_duplicate += static_cast<int32_t>(gate_.rejected(RejectReason::Duplicate));
  out_.samples_rejected = out_.rejected_nonfinite + out_.rejected_out_of_order + out_.rejected_duplicate;
  toLcm(out_, param_names_, coord_names_, out_msg_);
  if (out_.valid) ++valid_publications_;
  if (lcm_.publish(channels::kEstimate, out_msg_)) ++publications_;
  else ++publish_errors_;
}

bool EstimatorNode::resume(bool* resumed, std::string* error) {
  *resumed = false;
  if (opt_.checkpoint.empty()) return true;
  std::error_code ec;
  if (!std::filesystem::exists(opt_.checkpoint, ec)) return true;
  if (!est_.loadCheckpoint(opt_.checkpoint, error)) return false;
  *resumed = true;
  return true;
}

bool EstimatorNode::writeCheckpoint(std::string* error) {
  if (opt_.checkpoint.empty()) return true;
  last_checkpoint_ = std::chrono::steady_clock::now();
  if (est_.saveCheckpoint(opt_.checkpoint, &checkpoint_error_)) {
    ++checkpoints_;
    return true;
  }
  ++checkpoint_errors_;
  if (error) *error = checkpoint_error_;
  return false;
}

int EstimatorNode::poll(int timeout_ms, std::string* error) {
  int n = 0;
  if (receiver_) {
    const long r = receiver_->poll(timeout_ms, raw_handler_, kMaxDatagramsPerPoll);
    if (r < 0) {
      if (error) *error = std::string("receive: poll failed: ") + std::strerror(errno);
      return -1;
    }
    n = r > 0 ? 1 : 0;
  } else {
    n = lcm_.handleTimeout(timeout_ms, error);
    if (n < 0) return n;
  }
  if (!opt_.checkpoint.empty() && opt_.checkpoint_every_s > 0.0 &&
      std::chrono::duration<double>(std::chrono::steady_clock::now() - last_checkpoint_).count() >=
          opt_.checkpoint_every_s)
    writeCheckpoint(nullptr);
  return n;
}

EstimatorNode::Outcome EstimatorNode::run(int64_t idle_timeout_ms, const volatile std::sig_atomic_t* stop) {
  std::string err;
  while (!*stop) {
    const auto idle =
        std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - last_state_).count();
    if (idle_timeout_ms > 0 && idle >= idle_timeout_ms) {
      std::fprintf(stderr, "exo_estimator: no %s for %lld ms, exiting\n", channels::kState, static_cast<long long>(idle));
      return Outcome::IdleTimeout;
    }
    if (poll(kPollSliceMs, &err) < 0) {
      std::fprintf(stderr, "exo_estimator: LCM: %s\n", err.c_str());
      return Outcome::LcmError;
    }
  }
  return Outcome::Stopped;
}

}  // namespace exoid::estimator
