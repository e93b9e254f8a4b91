#pragma once
// One data file (an LCM log of `exoid experiment` or a CSV of measured data) through the dataset pipeline into
// regressor rows, for `exoid identify`, `diagnose` and `study`. The file is read by the intake layer
// (exoid/intake/measured_input.hpp): damaged input is refused naming the file and where, unless the options
// allow skipping (skip_bad_rows, allow_partial), and what was skipped is counted in intake::InputStats.
#include <array>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "exoid/estimator/batch/accumulator.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/intake/measured_input.hpp"
#include "exoid/estimator/batch/identify.hpp"
#include "exoid/model/model.hpp"

namespace exoid::tools {

/// Where the sensors pipeline takes a floating base's orientation, angular rate and linear acceleration from, as
/// `exoid identify`, `study` and `diagnose` take them (--base-orientation, --base-rate, --base-acceleration,
/// --orientation-cutoff; docs/identification.md "Input pipelines").
struct BaseSignals {
  /// "plates": the legs' orientation with the soles' tilt fitted to the plates' wrenches (SourceOptions::
  /// fit_sole_tilt); "fused": the legs' with the IMU's correction below orientation_cutoff_hz; "imu": the IMU's.
  std::string orientation = "plates";
  std::string rate = "legs";          ///< "legs" (DatasetOptions::base_rate_from_legs) or "gyro"
  std::string acceleration = "legs";  ///< "legs" (DatasetOptions::base_acceleration_from_legs) or "accelerometer"
  double orientation_cutoff_hz = 5.0;
  /// Where each sole stands on its plate: the sole frame's origin minus the plate's reported sensor origin, lab axes,
  /// m ([0] right, [1] left; `--sole-on-plate`). Zero: each sole centred on its plate, as exoid assumes unless told.
  /// The same for every file a command reads (the feet not moved between the runs).
  std::array<Eigen::Vector3d, 2> sole_on_plate{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  /// `--sole-on-plate fit`: the soles' common offset on their plates (x, y) fitted to each file's rows on top of
  /// sole_on_plate (SourceOptions::fit_sole_placement).
  bool fit_sole_placement = false;
};

struct SourceOptions;
/// `b` into so.dataset and so.fit_sole_tilt; the legs only in the sensors pipeline (the truth pipeline records the
/// base's motion). Set so.pipeline first.
void applyBaseSignals(const BaseSignals& b, SourceOptions& so);

/// Options for turning one data file into rows of the accumulator.
struct SourceOptions {
  intake::LogPipeline pipeline = intake::LogPipeline::Sensors;  ///< LCM logs only
  estimator::DatasetOptions dataset;
  /// Floating base, when dataset.footholds is empty: each default foothold's sole stands this far from its plate's
  /// reported origin ([0] right, [1] left; BaseSignals::sole_on_plate), lab axes, m.
  std::array<Eigen::Vector3d, 2> sole_on_plate{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  /// Floating base on its plates (not held_base): fit the soles' common offset on their plates to each file's rows
  /// first (estimator::SolePlacementFit; its rows built three times: as declared, and with both soles moved in x and
  /// in y) and use it on top of sole_on_plate where the data determine it; the file's intake::InputStats::
  /// sole_placement says what was found (`--sole-on-plate fit`).
  bool fit_sole_placement = false;
  bool skip_bad_rows = false;                   ///< CSV only
  /// With dataset.orientation_from_legs on a floating base: fit the soles' tilt on their contacts to the plates'
  /// wrenches over the whole file first (estimator::SoleTiltFit, one more pass over it), into dataset.sole_tilt and
  /// the file's intake::InputStats::sole_tilt (`--base-orientation plates`, the default; docs/identification.md).
  bool fit_sole_tilt = false;
  const estimator::EffectSet* effects = nullptr;  ///< a diagnose sidecar applied as known corrections (no delay)
  /// The run was recorded with the pelvis held still by a harness and the feet free (`exoid calibrate`): the base
  /// at rest (no velocity, no acceleration; orientation from the IMU, or the truth), no foot contact, and the rows
  /// that are not measured (estimator::heldBaseRowMeasured: the base's, the pinned unactuated joints') handed on
  /// as zero rows, K and y both, which carry no information into a least-squares fit. Floating base only.
  bool held_base = false;
  /// LCM logs: use the readable part of a damaged log (damage reported in intake::InputStats) instead of refusing it.
  bool allow_partial = false;
  /// Parameters held at known values (`exoid diagnose --declared-model`, `exoid identify --only-links`): every row's y
  /// becomes y - K held_phi [Model::nparams()], so what is fitted to it is what those parameters leave. Not owned.
  const Eigen::VectorXd* held_phi = nullptr;
  /// Only the floating base's 6 rows (`exoid identify --rows base`): the joints' rows are handed on as zero rows,
  /// K and y both. The base-link dynamics of a legged robot identify the same base parameters as the whole
  /// dynamics (Ayusawa, Venture and Nakamura, IJRR 33(3), 2014) and no joint torque enters them, so what the model
  /// lacks at the joints (a wearer's passive moments, friction, torque-sensor errors) cannot bias the inertials.
  bool base_rows_only = false;
  /// A linear function of the parameters held at a value (`exoid identify --com-height prior`): parameter j is
  /// eliminated, so every row's K becomes K - K_j c^T (column j zero) and y becomes y - K_j value, before held_phi
  /// is taken off (estimator::HeldFunction). Not owned.
  const estimator::HeldFunction* held_function = nullptr;
};

/// The measured samples of one file (the dataset pipeline's input: before noise, filtering and
/// differentiation), read once; accumulateSamples then turns them into (K, y) under any dataset options (e.g.
/// one filter cutoff after another, `exoid study`) without reading the file again.
bool readSamples(const std::string& path, const Model& model, const SourceOptions& options,
                 std::vector<estimator::MeasuredSample>& out, intake::InputStats& stats, std::string* error);
bool accumulateSamples(const std::vector<estimator::MeasuredSample>& samples, const Model& model,
                       const SourceOptions& options, estimator::LsqAccumulator& acc, intake::InputStats& stats,
                       std::string* error);

/// The same data processed another way, for the default rank rule's processing term (estimator::rankByJackknife):
/// what a systematic error of the processing would move, the jackknife over time blocks cannot see.
struct ProcessingAlternative {
  std::string what;      ///< e.g. "cutoff 15 Hz", "filtering the inputs", "IMU orientation"
  SourceOptions source;  ///< the training options with that one choice changed
};
/// The alternatives of a training pipeline: with a filter (cutoff > 0), half its cutoff, and with parallel filtering
/// also filtering the inputs (not the reverse: the parallel filter never changed the kept set on the exoskeleton's
/// runs and holds every column of the run in memory); on LCM logs of a floating-base robot (logs_on_floating_base; a
/// CSV carries its orientation) with the legs' orientation (SourceOptions::dataset.orientation_from_legs): with the
/// legs' rate or acceleration, the IMU's below the fusion cutoff (imu_below_fusion_cutoff), with the gyro's rate, the
/// IMU's orientation. Empty where the processing
/// has nothing to choose (unfiltered CSV data with recorded velocities and accelerations).
std::vector<ProcessingAlternative> processingAlternatives(const SourceOptions& training, bool logs_on_floating_base);

/// True if the path names a CSV (by its extension), false for anything else (read as an LCM log).
bool isCsvPath(const std::string& path);

/// Streams one file (LCM log or CSV) through the dataset pipeline (filtering, K and y), one sample at a time,
/// to a sink (accumulateFile below, `exoid diagnose`). Feet and footholds as for accumulateFile.
bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const estimator::RowSink& sink, intake::InputStats& stats, std::string* error);

/// The same, with the joint torque sensors' part of each y (estimator::DatasetBuilder::sensorTorque()) as the
/// sink's fourth argument: y minus it is what the plates contribute (zero for a fixed base).
using TorqueRowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                         const Eigen::VectorXd& tau_sensor)>;
bool streamFileRows(const std::string& path, const Model& model, const SourceOptions& options,
                    const TorqueRowSink& sink, intake::InputStats& stats, std::string* error);
/// The TorqueRowSink rows with the joint positions q [njoints] they were computed from
/// (DatasetBuilder::jointPosition()): the residual-predictability stage of `exoid diagnose` needs the state.
using StateRowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                        const Eigen::VectorXd& tau_sensor, const Eigen::VectorXd& q)>;
bool streamFileStateRows(const std::string& path, const Model& model, const SourceOptions& options,
                         const StateRowSink& sink, intake::InputStats& stats, std::string* error);

/// Streams one file (LCM log or CSV) through the dataset pipeline (filtering, K and y) into the accumulator.
/// Floating base: the feet are the model's right_foot / left_foot bodies; without a measured base position
/// the footholds are the right_sole / left_sole frames on their plates' sensor origins (each sole centred on
/// its plate's top, as placed in the lab). Rows the accumulator rejects (non-finite) are counted in
/// stats.why["non-finite regressor row"].
bool accumulateFile(const std::string& path, const Model& model, const SourceOptions& options,
                    estimator::LsqAccumulator& acc, intake::InputStats& stats, std::string* error);

}  // namespace exoid::tools
