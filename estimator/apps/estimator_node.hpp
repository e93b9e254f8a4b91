#pragma once
// exo_estimator's loop over LCM (the thin main parses options; this is what tests drive over memq://):
// EXO_STATE and EXO_PLATE_RIGHT/LEFT through a MessageGate (undecodable, non-finite, duplicate and out-of-order
// messages rejected and counted per reason) into the OnlineEstimator; EXO_ESTIMATE at tick-aligned rows (the
// first folded row at or after each row r with (r + 1) % publish_every == 0; inside the receive callback:
// allocation-free); the checkpoint written between receive calls (never inside the per-sample path), every
// checkpoint_every_s of wall time and on demand. What it publishes is a function of the messages it received
// only, never of timing: the consistent solve begun at one due publication is adopted at the second due one
// after (waited for), and a checkpoint only reads the estimator (docs/estimator.md "Determinism").
#include <array>
#include <future>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/lcm_endpoint.hpp>
#include <exoid/lcm/message_gate.hpp>
#include <memory>
#include <string>

#include "lcm_wire.hpp"

#include "exoid/estimator/online/online_estimator.hpp"

namespace exoid::estimator {

struct NodeOptions {
  int publish_every = 10;           ///< rows per EXO_ESTIMATE, tick-aligned (10: 100 Hz at 1 kHz)
  std::string checkpoint;           ///< path; empty: none
  double checkpoint_every_s = 5.0;  ///< wall seconds between checkpoints (<= 0: only on demand / exit)
  /// The consistent-parameter solve (OnlineEstimator::reconcile's three steps, ~10 ms), begun at every due
  /// publication (OnlineEstimator::reconcileDue) and adopted at the second due one after (used from the
  /// publication after that): on worker threads (samples keep being received meanwhile; the adopting
  /// publication waits for the solve if it is not done), or, false, in the publishing call. Either way the same
  /// publications, bit for bit.
  bool reconcile_async = true;
  /// On a udpm:// endpoint, receive from the node's own socket (lcmwire::UdpmReceiver: the kernel buffer holds
  /// bursts while the process is descheduled; LCM 1.3.1's lcm_handle ring drops them: 7-28 % of the samples in
  /// loaded lockstep runs, docs/estimator.md). Other URLs (memq://) always use the endpoint's subscriptions.
  bool raw_udpm = true;
  size_t recv_buffer_bytes = size_t{64} << 20;  ///< kernel receive buffer of the raw socket
};

class EstimatorNode {
 public:
  /// Subscribes on `lcm` (which must outlive the node), or opens its own socket on lcm's udpm:// group
  /// (options.raw_udpm). Check ok() / error() afterwards (the socket may fail to join).
  EstimatorNode(LcmEndpoint& lcm, const Model& model, OnlineEstimator& estimator, const NodeOptions& options);
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }
  /// Receiving through the raw socket (else the endpoint's subscriptions).
  bool rawReceive() const { return receiver_ != nullptr; }

  /// Restores the checkpoint when its file exists. False with *error when it exists but is refused (another
  /// estimator's, damaged): the caller decides (exo_estimator exits 2 rather than silently starting over).
  bool resume(bool* resumed, std::string* error);
  /// One receive step (at most timeout_ms), then a due checkpoint. Returns handleTimeout's result (< 0: LCM
  /// failure, *error set) — a checkpoint that cannot be written is reported in *checkpoint_error and counted.
  int poll(int timeout_ms, std::string* error);
  bool writeCheckpoint(std::string* error);
  /// Why run() returned.
  enum class Outcome { Stopped, IdleTimeout, LcmError };
  /// poll() in slices of 50 ms until *stop is set, or no state arrived for idle_timeout_ms (> 0; reported on
  /// stderr), or an LCM failure (reported on stderr).
  Outcome run(int64_t idle_timeout_ms, const volatile std::sig_atomic_t* stop);

  long publications() const { return publications_; }
  /// Due publications that had to wait for the worker's consistent solve (reconcile_async).
  long reconcileWaits() const { return reconcile_waits_; }
  double reconcileWaitMax() const { return reconcile_wait_max_s_; }  ///< s, the longest of those waits
  double reconcileWaitTotal() const { return reconcile_wait_s_; }    ///< s, all of them
  long publishErrors() const { return publish_errors_; }
  long validPublications() const { return valid_publications_; }  ///< estimates published with valid = 1
  long checkpointsWritten() const { return checkpoints_; }
  long checkpointErrors() const { return checkpoint_errors_; }
  const std::string& lastCheckpointError() const { return checkpoint_error_; }
  const EstimatorOutputSample& lastOutput() const { return out_; }
  const MessageGate& gate() const { return gate_; }
  /// Wall time of the last state message (idle detection).
  std::chrono::steady_clock::time_point lastState() const { return last_state_; }

 private:
  void maybePublish();
  void publish();
  /// At a due publication: adopts the consistent solve begun kReconcileDepth due publications ago (waiting for
  /// its worker), begins the next.
  void cycleReconcile();
  void onState(const void* data, int size);
  void onPlate(int i, const void* data, int size);
  LcmEndpoint& lcm_;
  std::string error_;
  std::unique_ptr<lcmwire::UdpmReceiver> receiver_;
  lcmwire::UdpmReceiver::Handler raw_handler_;
  const Model& model_;
  OnlineEstimator& est_;
  NodeOptions opt_;
  // The consistent solves in flight, begun at the last kReconcileDepth due publications (ring, oldest next_job_).
  static constexpr int kReconcileDepth = 2;
  std::array<OnlineEstimator::ReconcileJob, kReconcileDepth> jobs_;
  std::array<std::future<void>, kReconcileDepth> pending_;  ///< the worker's solve of each job, when one runs
  std::array<bool, kReconcileDepth> job_begun_{};           ///< begun, not yet adopted
  int next_job_ = 0;
  long next_row_ = -1;         ///< publish at the first row >= this (aligned); -1 before the first row
  long reconcile_waits_ = 0;
  double reconcile_wait_max_s_ = 0.0, reconcile_wait_s_ = 0.0;
  MessageGate gate_;
  int ch_state_ = 0, ch_plate_[2] = {0, 0};
  std::vector<std::string> joint_names_, param_names_, coord_names_;
  RobotStateSample state_;
  ForcePlateSample plate_;
  exoid_lcm::robot_state_t state_msg_;
  exoid_lcm::force_plate_t plate_msg_;
  exoid_lcm::estimator_output_t out_msg_;
  EstimatorOutputSample out_;
  long valid_publications_ = 0;
  long publications_ = 0, publish_errors_ = 0, checkpoints_ = 0, checkpoint_errors_ = 0;
  std::string checkpoint_error_;
  std::chrono::steady_clock::time_point last_checkpoint_, last_state_;
};

}  // namespace exoid::estimator
