#pragma once
// Streaming readers for `exoid identify`: an LCM log of `exoid experiment` or a CSV of measured data, turned
// into estimator::MeasuredSample one at a time, so memory does not grow with the data length. Damaged input
// is reported with the file, row/tick, column and value; with skip_bad_rows bad rows/ticks are dropped and
// counted instead.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/model.hpp"

namespace exoid::tools {

/// Which samples of a run log to use.
enum class LogPipeline {
  Sensors,  ///< EXO_STATE + both plates: encoders, torque sensors, IMU, plates (what a lab has)
  Truth,    ///< EXO_TRUTH (exact state, applied torques) + both plates: the thesis protocol's input
};

struct InputStats {
  long samples = 0;                 ///< handed to the sink
  long skipped = 0;                 ///< bad rows / incomplete or out-of-order ticks dropped
  std::map<std::string, long> why;  ///< skipped, by reason
  std::string first_skip;           ///< where and why the first one was skipped
  long rejected_events = 0;         ///< log events the adapters rejected (LCM only)
};

using SampleSink = std::function<bool(const estimator::MeasuredSample&, std::string* error)>;

/// Streams a run log in tick order. A tick missing a needed channel is skipped and counted (never an
/// error); a message for a tick older than one already passed on is counted as out of order.
/// feet: the model's right and left foot bodies. False with *error if the file is not a readable LCM log,
/// holds none of the needed channels, or the sink fails.
bool streamRunLog(const std::string& path, const Model& model, LogPipeline pipeline, const int feet[2],
                  const SampleSink& sink, InputStats& stats, std::string* error);

/// Streams a measured-data CSV (docs/identification.md): `t`, `q_<joint>` for every joint, `tau_<joint>`
/// for every actuated joint (URDF effort limit > 0; absent columns of unactuated joints read as 0),
/// optional `v_<joint>` and `a_<joint>` (all joints or none), and for a floating base `base_qw..qz`,
/// `base_wx..wz`, `base_ax..az`, `fp_<right|left>_<fx..nz>`, optional `base_dwx..dwz`, `base_px..pz`.
/// Rejected rows: wrong cell count (also a truncated last line), a cell that is not a finite number,
/// a time not after the previous row's, an absurd value (|q| beyond the joint limits by more than 1 rad
/// or above 100 rad without limits, |v| > 1e3 rad/s, |a| > 1e5 rad/s^2, |tau| > 100 x the effort limit or 1e5,
/// a quaternion off unit norm by more than 1e-3, |force| > 1e6 N). Without skip_bad_rows the first one is
/// an error naming the row, column and value.
bool streamMeasuredCsv(const std::string& path, const Model& model, const int feet[2], bool skip_bad_rows,
                       const SampleSink& sink, InputStats& stats, std::string* error);

/// Options for turning one data file into rows of the accumulator.
struct SourceOptions {
  LogPipeline pipeline = LogPipeline::Sensors;  ///< LCM logs only
  estimator::DatasetOptions dataset;
  bool skip_bad_rows = false;                   ///< CSV only
  const estimator::EffectSet* effects = nullptr;  ///< a diagnose sidecar applied as known corrections (no delay)
  /// The run was recorded with the pelvis held still by a harness and the feet free (`exoid calibrate`): the base
  /// at rest (no velocity, no acceleration; orientation from the IMU, or the truth), no foot contact, and the rows
  /// that are not measured (estimator::heldBaseRowMeasured: the base's, the pinned unactuated joints') handed on
  /// as zero rows, K and y both, which carry no information into a least-squares fit. Floating base only.
  bool held_base = false;
};

/// The measured samples of one file (the dataset pipeline's input: before noise, filtering and
/// differentiation), read once; accumulateSamples then turns them into (K, y) under any dataset options (e.g.
/// one filter cutoff after another, `exoid study`) without reading the file again.
bool readSamples(const std::string& path, const Model& model, const SourceOptions& options,
                 std::vector<estimator::MeasuredSample>& out, InputStats& stats, std::string* error);
bool accumulateSamples(const std::vector<estimator::MeasuredSample>& samples, const Model& model,
                       const SourceOptions& options, estimator::LsqAccumulator& acc, InputStats& stats,
                       std::string* error);

/// True if the path names a CSV (by its extension), false for anything else (read as an LCM log).
bool isCsvPath(const std::string& path);

/// Streams one file (LCM log or CSV) through the dataset pipeline (filtering, K and y), one sample at a time,
/// to a sink (accumulateFile below, `exoid diagnose`). Feet and footholds as for accumulateFile.
bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const estimator::RowSink& sink, InputStats& stats, std::string* error);

/// The same, with the joint torque sensors' part of each y (estimator::DatasetBuilder::sensorTorque()) as the
/// sink's fourth argument: y minus it is what the plates contribute (zero for a fixed base).
using TorqueRowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                         const Eigen::VectorXd& tau_sensor)>;
bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const TorqueRowSink& sink, InputStats& stats, std::string* error);
/// The TorqueRowSink rows with the joint positions q [njoints] they were computed from
/// (DatasetBuilder::jointPosition()): the residual-predictability stage of `exoid diagnose` needs the state.
using StateRowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                        const Eigen::VectorXd& tau_sensor, const Eigen::VectorXd& q)>;
bool streamFileStateRows(const std::string& path, const Model& model, const SourceOptions& options,
                         const StateRowSink& sink, InputStats& stats, std::string* error);

/// Streams one file (LCM log or CSV) through the dataset pipeline (filtering, K and y) into the accumulator.
/// Floating base: the feet are the model's right_foot / left_foot bodies; without a measured base position
/// the footholds are the right_sole / left_sole frames on their plates' sensor origins (each sole centred on
/// its plate's top, as placed in the lab). Rows the accumulator rejects (non-finite) are counted in
/// stats.why["non-finite regressor row"].
bool accumulateFile(const std::string& path, const Model& model, const SourceOptions& options,
                    estimator::LsqAccumulator& acc, InputStats& stats, std::string* error);

}  // namespace exoid::tools
