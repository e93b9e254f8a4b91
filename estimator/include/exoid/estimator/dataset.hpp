#pragma once
// From a run's samples to the identification data (W, y) of K(q, v, dv) phi = y, shared by the batch
// solvers, the online estimator and the diagnosis (docs/identification.md):
//   - sample alignment by control tick (a tick missing a needed message is skipped and counted);
//   - the state from samples (ground truth, or sensors: encoders + IMU + leg kinematics for the base position);
//   - plate wrench -> wrench on the foot -> generalized forces (thesis eq. 4, measurement.hpp);
//   - filtering: zero-phase 2nd-order Butterworth of the regressor's inputs (thesis III-E) and, with
//     parallel filtering, the same filter on every column of W and on y;
// streamed block by block so that memory does not depend on the length of the run.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "exoid/estimator/measurement.hpp"
#include "exoid/estimator/tick_assembly.hpp"
#include "exoid/model/model.hpp"
#include "exoid/samples.hpp"
#include "exoid/signal/filters.hpp"

namespace exoid::estimator {

/// The exact state of a ground-truth sample (every State field).
State stateFromTruth(const Model& model, const GroundTruthSample& truth);

/// Wrench on a foot from its plate's sample: force ON the foot (world) and its moment about the WORLD
/// origin (world): f = -R_p force, n_O = -(R_p moment + p_plate x R_p force).
void footWrenchFromPlate(const ForcePlateSample& plate, Eigen::Vector3d& force, Eigen::Vector3d& moment_world_origin);

/// One control tick with the messages of every channel that carried it (nullptr where absent).
struct AlignedTick {
  const RobotStateSample* state = nullptr;
  const ForcePlateSample* plate[2] = {nullptr, nullptr};  ///< right, left
  const GroundTruthSample* truth = nullptr;
};

/// Which channels a tick must have to be kept.
struct TickNeeds {
  bool state = true, plates = true, truth = false;
};

/// Aligns channels by tick with the one tick assembly (tick_assembly.hpp, window kLogLagWindow): one entry
/// per tick that has every needed channel, in tick order, with the first message of that tick on each channel
/// (nullptr where a channel not needed is absent). The channels are offered merged by tick, each in its own
/// order. A repeated message of a tick (e.g. the state twice) is dropped, keeping the first, and counted in
/// counts->duplicates. *skipped: ticks of the driving channel (the states if needs.state, else the truth)
/// missing another needed channel.
std::vector<AlignedTick> alignByTick(const std::vector<RobotStateSample>& states,
                                     const std::vector<ForcePlateSample>& plates_right,
                                     const std::vector<ForcePlateSample>& plates_left,
                                     const std::vector<GroundTruthSample>& truth, const TickNeeds& needs,
                                     long* skipped, TickAssemblyCounts* counts = nullptr);

/// One aligned measurement, the input of the dataset pipeline. Sizes [njoints]; v, a empty when not
/// measured (then derived by differentiation); has_* say which base fields are measured.
struct MeasuredSample {
  double t = 0.0;  ///< seconds
  Eigen::VectorXd q, v, a, tau;
  // Floating base only (base coordinates unless stated):
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< world <- base
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();  ///< world; needed by the plate moments
  Eigen::Vector3d base_omega = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_domega = Eigen::Vector3d::Zero();
  Eigen::Vector3d base_acceleration = Eigen::Vector3d::Zero();  ///< classical, gravity excluded
  bool has_base_position = false;  ///< false: from leg kinematics (feet on their sole points, see below)
  bool has_base_domega = false;    ///< false: derived from base_omega
  ExternalWrench contact[2];       ///< wrench on each foot (force world, moment about the world origin)
  int ncontacts = 0;
  Eigen::Vector3d plate_position[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  ///< plates' sensor
                                   ///< origins (world) as the lab measured them, when from plates
};

/// A sample from the ground-truth channel: exact state; y from the applied torques and the plates (when both
/// are given) or MuJoCo's contact wrenches. feet: the model's right/left foot bodies.
void measuredFromTruth(const Model& model, const GroundTruthSample& truth, const ForcePlateSample* plates[2],
                       const int feet[2], MeasuredSample& out);

/// A sample from the sensors only (what a lab has): encoders, joint torque sensors (0 where absent), IMU
/// orientation and gyro (IMU frame = base frame), accelerometer + R^T g as the base acceleration, plates.
/// No base position, no derivatives: the pipeline derives them.
void measuredFromSensors(const Model& model, const RobotStateSample& state, const ForcePlateSample* plates[2],
                         const int feet[2], MeasuredSample& out);

/// Thesis III-E on a signal [samples x channels] at uniform sample time dt: xf = F(x), dx = F(D xf),
/// ddx = F(D dx), F the zero-phase 2nd-order Butterworth at cutoff_hz (identity when cutoff_hz <= 0), D central
/// differences. Any output may be null. Requires cutoff_hz < 0.5 / dt (checked by the callers).
void filterAndDifferentiate(const Eigen::MatrixXd& x, double dt, double cutoff_hz, Eigen::MatrixXd* xf,
                            Eigen::MatrixXd* dx, Eigen::MatrixXd* ddx);

/// The soles' tilt on their contacts as a linear function of the plates' wrenches (sole_tilt.hpp, SoleTiltFit): the
/// legs' orientation error e = log(R_legs^T R_wb) (base coordinates) ~ coefficients x, x [13] = [1, f_0, n_0, f_1, n_1].
constexpr int kSoleTiltRegressors = 13;  ///< x's length
/// The legs' orientation takes each sole's world orientation R_ws from this many first samples (DatasetBuilder and
/// SoleTiltFit alike: a fixed count, so that the block size does not matter).
constexpr int kSoleWorldSamples = 1000;

struct SoleTilt {
  bool fitted = false;
  /// Per axis (x, y, z of the base), a bit per column of x kept by the selection (bit 0: the constant).
  int columns[3] = {0, 0, 0};
  Eigen::Matrix<double, 3, kSoleTiltRegressors> coefficients = Eigen::Matrix<double, 3, kSoleTiltRegressors>::Zero();
  long samples = 0;
  Eigen::Vector3d correction_rms = Eigen::Vector3d::Zero();  ///< rad, RMS of the IMU's correction e per axis
  Eigen::Vector3d explained_rms = Eigen::Vector3d::Zero();   ///< rad, RMS of the fit C x about its mean
  Eigen::Vector3d residual_rms = Eigen::Vector3d::Zero();    ///< rad, what it leaves: the IMU's noise, what is not linear
};

enum class FilterMode {
  Inputs,    ///< thesis III-E: filter q (and the gyro), differentiate, filter the derivatives; y untouched
  Parallel,  ///< inputs only differentiated (no filter; the short zero-phase fit of derivative_half_window), then
             ///< the zero-phase filter on every column of W and on y: F(W) phi = F(y) wherever W phi = y (filter
             ///< lag and attenuation cancel)
};

struct DatasetOptions {
  double cutoff_hz = 0.0;            ///< zero-phase 2nd-order Butterworth cutoff; <= 0: no filter
  FilterMode filter = FilterMode::Inputs;
  bool derive = false;               ///< true: v, a (and base dw) by differences even where measured
  /// Parallel mode with a filter: v, a (and the gyro's value and slope) from the least-squares quadratic over
  /// 2L + 1 samples (savitzkyGolay), as the online estimator does; 1 = central differences. The squared noise of
  /// differenced encoders in W's velocity products is a bias the filter after it cannot remove (docs/estimator.md).
  int derivative_half_window = 30;
  double encoder_noise = 0.0;        ///< sigma (rad) of white noise added to q before anything (thesis: 9e-6)
  uint64_t noise_seed = 1;
  /// Sole points (body, point in body coordinates, world position) for the base position from leg
  /// kinematics when a sample has none: p_b = p_world - R_wb * p_body(q), averaged over the feet.
  struct Foothold {
    int body = -1;
    Eigen::Vector3d point_in_body = Eigen::Vector3d::Zero();
    Eigen::Matrix3d rotation_in_body = Eigen::Matrix3d::Identity();  ///< body <- sole frame
    Eigen::Vector3d world = Eigen::Vector3d::Zero();  ///< plus the sample's plate_position[plate] if plate >= 0
    int plate = -1;
  };
  std::vector<Foothold> footholds;
  /// Base orientation fused from the IMU and leg kinematics (samples without a base position only): the
  /// soles stand flat and still, so R_legs = R_ws R_bs(q)^T per foot (chordal mean over the feet; each sole's
  /// world orientation R_ws estimated once as the chordal mean of R_IMU R_bs(q) over the first 1000 samples), precise
  /// (encoders) but biased where the feet tilt on their contacts; the IMU is unbiased but noisy. Complementary:
  /// R_wb = R_legs exp(LP(log(R_legs^T R_IMU))) with LP the zero-phase Butterworth at orientation_cutoff_hz
  /// (the IMU below it, the legs above). The classical base acceleration is re-based on R_wb (accelerometer +
  /// R_wb^T g).
  bool orientation_from_legs = false;
  double orientation_cutoff_hz = 5.0;
  /// With orientation_from_legs, where fitted: the legs' error from this fit of the IMU's correction to the plates'
  /// wrenches (SoleTiltFit over the same run first; the tools' readers do it, tools::SourceOptions::fit_sole_tilt)
  /// instead of the IMU's band below orientation_cutoff_hz: the IMU's noise is then averaged over the run, not
  /// passed below the cutoff. R_wb = R_legs exp(coefficients x).
  SoleTilt sole_tilt;
  /// The base's angular velocity and acceleration from the legs instead of the gyro (samples without a base
  /// position only, footholds given): with the soles flat and still, R_wb = R_ws R_bs(q)^T (chordal mean over the
  /// feet, R_ws as above), so omega = vee(R^T dR/dt) and domega = vee(R^T d2R/dt2) (base frame, as the gyro's),
  /// the nine entries of R differentiated exactly as the joints' q (filterAndDifferentiate, or the Savitzky-Golay
  /// fit in parallel mode): the encoders' precision (9e-6 rad) instead of the gyro's white noise (3.6e-3 rad/s),
  /// which differentiated through the filter was the largest processing error of the exoskeleton's sensor runs
  /// (docs/identification.md). A foot that rolls on its plate breaks the assumption.
  bool base_rate_from_legs = false;
  /// The base origin's classical acceleration from the legs instead of the accelerometer (same conditions): the
  /// base position the plate moments use, p_b = p_sole - R_wb p_sole^b(q) with R_wb from the legs alone (above),
  /// differentiated twice as q is, in base coordinates R^T p_b''. Gravity and the plates' wrenches then enter the
  /// base rows through the same R, so an orientation error leaves a standing robot's statics balanced; the
  /// accelerometer's specific force holds the true R, the wrenches the estimated one (docs/identification.md).
  bool base_acceleration_from_legs = false;
  /// With orientation_from_legs: the legs' rate and acceleration (above) take the IMU's (gyro, accelerometer) below
  /// orientation_cutoff_hz, as the orientation does. Not the default (the gyro's share below 5 Hz still costs
  /// more than the feet's tilt on their contacts); with the fused orientation the rank rule's processing check
  /// compares it.
  bool imu_below_fusion_cutoff = false;
  int block = 4096;                  ///< samples processed per block (memory ~ (block + 2 margin) x nv x p)
  /// With a filter: drop the samples within the filter's settling time (transient below e^-14, ~1e-6) of the
  /// run's first and last sample. A zero-phase filter has neither past nor future there; with differenced
  /// encoders the start-up transient reached 40 N m on the exoskeleton's hip rows (docs/diagnose.md). Off by
  /// default so that every sample has a row (the exactness tests compare sample by sample).
  bool trim_edges = false;
};

/// A run with the pelvis held by a harness (`exoid calibrate`): whether row `row` of K, y is measured. The base
/// rows are not (the harness's wrench is unknown), nor are the rows of unactuated joints (URDF effort limit 0:
/// the harness pins them, with an unmeasured torque); the actuated joints' rows are.
bool heldBaseRowMeasured(const Model& model, int row);

/// The footholds of a lab setup: the model's `right_sole` / `left_sole` frames on their plates' sensor origins
/// plus sole_on_plate[plate] (where each sole stands on its plate, lab axes, m: `--sole-on-plate`; zero, the
/// default, is each sole centred on its plate); frames the model lacks are skipped.
std::vector<DatasetOptions::Foothold> defaultFootholds(
    const Model& model,
    const std::array<Eigen::Vector3d, 2>& sole_on_plate = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});

/// Base position (world) from leg kinematics: each foothold's point stays where the lab placed it,
/// p_b = p_world - R_wb p_base(q), averaged over the footholds. Requires forwardKinematics (kin.p, kin.R) of
/// the state; plate_position [2]: the plates' sensor origins (world). Allocation-free.
Eigen::Vector3d basePositionFromFootholds(const std::vector<DatasetOptions::Foothold>& footholds, const Data& kin,
                                          const Eigen::Matrix3d& R_world_base, const Eigen::Vector3d plate_position[2]);

/// Callback receiving the identification data of one sample: K [nv x p] and y [nv] (both after filtering).
using RowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y)>;

/// Streams measured samples to (K, y) per sample. Samples must come at a uniform rate (the sample time is
/// the median step of each block); call finish() after the last sample. Zero-phase filtering is done per
/// block over the block plus a margin on each side long enough for the filter's transient to decay below
/// 1e-15 (so the result equals filtering the whole run at once, to round-off), which keeps memory bounded.
class DatasetBuilder {
 public:
  /// Fails (returns false with *error) on an invalid cutoff for the sample rate at the first block.
  DatasetBuilder(const Model& model, const DatasetOptions& options, RowSink sink);
  bool add(const MeasuredSample& sample, std::string* error);
  bool finish(std::string* error);
  long samples() const { return emitted_; }
  /// The joint torque sensors' part of the y being handed to the sink (S^T tau [nv]: tau_j on joint j's row, 0 on
  /// the base rows), processed like y (filtered with parallel filtering). Valid only inside the sink call;
  /// y minus it is the part the external wrenches (plates) contribute.
  const Eigen::VectorXd& sensorTorque() const { return sensor_torque_; }
  /// The joint positions q [njoints] the row being handed to the sink was computed from (filtered in Inputs mode, as
  /// measured in Parallel mode). Valid only inside the sink call.
  const Eigen::VectorXd& jointPosition() const { return joint_position_; }
  /// Samples not emitted because of trim_edges.
  long trimmed() const { return trimmed_; }
  /// Margin (samples) on each side of a block for the filter's transient to die out.
  int margin() const { return margin_; }

 private:
  /// One block of buffer_ to rows: filters designed, signals filtered and differentiated, orientation fused,
  /// regressor rows emitted, history kept. The stages below, in that order.
  bool processBlock(bool last, std::string* error);
  struct BlockSignals;
  /// The filters for the window's median step, the lookahead they need (want) and edge_ (trim_edges); false
  /// on a cutoff at or above Nyquist.
  bool designFilters(BlockSignals& b, int& want, std::string* error);
  /// A signal [n x channels] differentiated as q is: the Savitzky-Golay fit in parallel mode (derivative_half_window
  /// > 1), else filterAndDifferentiate at the input cutoff. Any output may be null, or x itself.
  void derivatives(const BlockSignals& b, const Eigen::MatrixXd& x, Eigen::MatrixXd* value, Eigen::MatrixXd* first,
                   Eigen::MatrixXd* second) const;
  /// q, v, a [n x nj]: measured (filtered) or differentiated (derivatives).
  void jointSignals(BlockSignals& b) const;
  /// Floating base: omega, domega (measured or differentiated) and the classical acceleration [n x 3].
  void baseSignals(BlockSignals& b) const;
  /// R_wb from the legs alone per sample (R_ws of the soles from the first 1000 samples' IMU orientation):
  /// b.legs_rotation [n] and the footholds' mean point in base coordinates b.sole_in_base [n], for
  /// fuseOrientation, legsRate and legsAcceleration.
  void legsRotations(BlockSignals& b);
  /// The base orientation from the legs with the IMU's low-passed correction; the accelerometer's gravity term
  /// re-based on it.
  void fuseOrientation(BlockSignals& b) const;
  /// base_rate_from_legs: b.w, b.dw from b.legs_rotation, differentiated as the joints' q are.
  void legsRate(BlockSignals& b) const;
  /// base_acceleration_from_legs: b.acc from b.legs_rotation and b.sole_in_base, differentiated as q is.
  void legsAcceleration(BlockSignals& b) const;
  /// A legs' signal with the IMU's below the orientation's fusion cutoff (imu_below_fusion_cutoff with the fused
  /// orientation): legs + LP(imu - legs); else legs itself.
  Eigen::MatrixXd withImuBelowFusionCutoff(const BlockSignals& b, const Eigen::MatrixXd& legs, const Eigen::MatrixXd& imu) const;
  /// trim_edges: false for the run's first edge_ samples and, in the last block, its last edge_ (counted).
  bool keepSample(int i, int n, bool last);
  void setSensorTorque(const Eigen::VectorXd& tau);  ///< joint torques into sensor_torque_ [nv]
  /// K and y of every sample to emit (or, parallel filtering, of the whole window into Kall_, Yall_, Tall_).
  void regressWindow(const BlockSignals& b, bool last, int emit_end);
  /// Parallel filtering: W, y and tau of the window filtered (zero phase, every channel), [head_, emit_end) emitted.
  void emitFilteredWindow(const BlockSignals& b, bool last, int emit_end);
  const Model& model_;
  DatasetOptions opt_;
  RowSink sink_;
  std::vector<MeasuredSample> buffer_;  ///< [margin_ history][block][margin_ lookahead]
  std::vector<Eigen::Matrix3d> sole_world_;  ///< [footholds] R_ws (orientation_from_legs), once known
  long emitted_ = 0;
  long seen_ = 0;  ///< samples dropped from the front of buffer_ so far (global index of buffer_[0])
  long trimmed_ = 0;
  int edge_ = 0;   ///< samples trimmed at each end of the run (trim_edges with a filter)
  int head_ = 0;  ///< samples at the front of buffer_ already emitted (history)
  /// Parallel filtering: W [window x nv p] (sample i's row c of K at columns c p..c p + p - 1), y [window x nv] and
  /// tau [window x nj] over the window, sample-major (one sample's values contiguous), kept between blocks;
  /// filter_scratch_: filtfiltInPlace's.
  SampleMajorMatrix Kall_, Yall_, Tall_, filter_scratch_;
  Eigen::VectorXd sensor_torque_;       ///< see sensorTorque()
  int margin_ = 0;
  uint64_t rng_ = 0;
  Eigen::VectorXd joint_position_;      ///< see jointPosition()
};

}  // namespace exoid::estimator
