#pragma once
// The online estimator's loop as a library (docs/estimator.md): sensor samples in (robot state and both force
// plates of each tick; never the ground truth), EstimatorOutputSample out at the publication rate. Used by
// build/bin/exo_estimator (estimator/apps) and in-process by the tests.
//
// Per tick k (all three messages of tick k present):
//   1. causal state reconstruction of tick k-1 by central differences over ticks k-2, k-1, k (the batch
//      pipeline's differences, one tick late, so q, v, a and y all belong to the same instant: no phase
//      error between them): v = (q_k - q_{k-2}) / 2dt, a = (q_k - 2 q_{k-1} + q_{k-2}) / dt^2, base angular
//      acceleration likewise from the gyro, base acceleration = accelerometer + R^T g, base position from
//      leg kinematics (dataset.hpp), y from the torque sensors and the plates (measurement.hpp);
//   2. the regressor K(q, v, dnu) [nv x p];
//   3. the same causal Butterworth on the structural entries of K and on y (CausalRowFilter: the filter is
//      linear and time-invariant, so its lag and attenuation cancel in F(K) phi = F(y));
//   4. the recursive WLS update (recursive_ls.hpp).
// At publication: solve, uncertainty, standard parameters, consistency, excitation, residuals, tau_correction.
//
// Real time: everything is sized by the constructor / sizeOutput(); addState, addPlate and fillOutput allocate
// nothing and throw nothing. Checkpoints do file I/O: call them off the per-sample path.
#include <array>
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/online/recursive_ls.hpp"
#include "exoid/estimator/online/row_filter.hpp"
#include "exoid/estimator/tick_assembly.hpp"
#include "exoid/model/model.hpp"
#include "exoid/sample_checks.hpp"
#include "exoid/samples.hpp"
#include "exoid/status_samples.hpp"

namespace exoid::estimator {

/// Integrated autocorrelation time (samples) of white noise through the causal Butterworth of the given cutoff and
/// order at sample_hz: (sum_k h_k)^2 / sum_k h_k^2 over its impulse response h; 1 without a filter. A mean over N
/// filtered samples has the variance of N / T independent ones (4th order, 2 Hz at 1 kHz: T ~ 240).
double filterCorrelationTime(double cutoff_hz, double sample_hz, int order);

enum class Forgetting {
  None,        ///< lambda = 1: the exact minimiser of the batch regularised cost
  Stabilised,  ///< every direction's data information decays by lambda per sample, the prior never does
  Selective,   ///< only the base-parameter axes the latest block excited are forgotten (no windup)
};
const char* forgettingName(Forgetting f);          ///< "none", "stabilised", "selective"
bool parseForgetting(const std::string& name, Forgetting& f);

/// How the rows (generalized coordinates) are weighted (docs/estimator.md, "Row weights").
enum class RowWeighting {
  Fixed,  ///< g_c = row_weight (ones when empty) throughout
  WlsR,   ///< the thesis's WLS-R (eqs. 29-32) online: g_c = 1 / sigma_c, sigma_c the residual RMS of row c
  /// WLS-R per independent sample: g_c = 1 / (sigma_c sqrt(T_c)), sigma_c and T_c the residual RMS and correlation
  /// time of row c (the samples one independent residual spans: the 2 Hz filter alone makes it ~244, model error
  /// up to ~4000) against a first, full-information (WLS-R) solve of the same sums. The data then carry the
  /// information of their independent samples, not of every 1 kHz row, so the prior keeps its weight against them
  /// where they inform little (the CoM height while standing), and the covariance A^-1 is the sandwich's.
  WlsRCorrelated,
};
const char* rowWeightingName(RowWeighting w);  ///< "fixed", "wls-r", "wls-r-corr"
bool parseRowWeighting(const std::string& name, RowWeighting& w);

struct OnlineEstimatorOptions {
  double sample_hz = 1000.0;     ///< tick rate of the samples
  double cutoff_hz = 2.0;        ///< causal Butterworth on K rows and y; <= 0: none (docs/estimator.md, "Filter")
  int filter_order = 4;          ///< its order (even, 2..8): 4 makes twice-differenced noise in K integrable
  /// The derivatives of a tick's state (v, a from the encoders; the gyro and its derivative) are those of the
  /// quadratic least-squares fit (Savitzky-Golay) over the 2L + 1 ticks around it, evaluated L ticks late;
  /// 1 = central differences. Noise products in K (v v^T of
  /// the encoders differenced at 1 kHz) do not average out in the filter that follows (docs/estimator.md, "State").
  int derivative_half_window = 30;
  int gyro_half_window = 20;     ///< the same fit for the gyro's value and slope (its noise is 400x the encoders')
  /// The base's angular velocity and acceleration from the legs instead of the gyro: both feet stand flat on
  /// their plates, so R_wb = R_wf R_bf(q)^T with R_wf constant, and the same fit through the rotation of R_bf(q)
  /// over the window (encoder noise, 9e-6 rad, against the gyro's 3.6e-3 rad/s) gives omega and its derivative.
  /// A foot that rolls on its plate breaks the assumption (docs/estimator.md, "State").
  bool base_rate_from_legs = true;
  double prior_relative = 0.25;  ///< prior within +-this (relative) of each standard parameter (1 sigma)
  std::vector<double> row_weight;  ///< [nv] row weights g_c, fixed or the reweighting's start; empty: ones
  /// WLS-R weights 1 / sigma_c from the residuals let every row count as an independent sample: on runs whose
  /// residuals are model error (soft contacts, undeclared joint effects) the data then outweigh the prior
  /// ~1000x too much and their misfit biases the CoM height by 2-13 mm, beyond its stated uncertainty. The
  /// correlated variant weights each row by its independent samples (docs/estimator.md, "Row weights").
  /// Selective forgetting always keeps row_weight fixed (its carried information holds the weights it was folded
  /// with).
  RowWeighting row_weighting = RowWeighting::WlsRCorrelated;
  Forgetting forgetting = Forgetting::None;
  double lambda = 0.9995;        ///< per-sample forgetting factor (Stabilised, Selective); memory 1 / (1 - lambda)
  int forget_every = 100;        ///< Selective: samples per block (forgetting step at the first publication after)
  double block_threshold = 1e-3; ///< Selective: axis j excited by a block when its information >= this x Lambda0_jj
  double excited_gain = 3.0;     ///< base parameter j counts as excited when prior var / posterior var >= 1 + this
  /// `valid` needs excitation >= this. 0: no such gate, the controller's trust rule weighs every quantity it uses
  /// by its own uncertainty; with information counted per independent sample (RowWeighting::WlsRCorrelated) a
  /// run with large model error informs few axes 4x beyond the prior (combined_worst: 17 %) while its payloads'
  /// mass and CoM stand far out of their sigma (docs/estimator.md, "Publication").
  double min_excitation = 0.0;
  int uncertainty_every = 10;    ///< covariance (m^3) and the stddevs at every N-th publication (kept between)
  /// Consistent standard parameters (reconcile()): a solve every N-th publication (<= 0: never; the published
  /// parameters are then the prior's conditional mean and `consistent` stays false).
  int consistent_every = 10;
  int consistent_iterations = 30;  ///< Levenberg-Marquardt iterations per solve (warm-started from the last)
  /// `consistent` needs the misfit ratio rho = sqrt((B phi_c - x)^T A (B phi_c - x) / RSS_w(x)) <= this: what
  /// the consistent parameters add to the weighted residual cost, relative to the cost itself (docs/estimator.md).
  double consistent_tolerance = 2.0;
  /// Residual-triggered forgetting (docs/estimator.md, "Change detection"): the innovation e = y - K x of each
  /// filtered sample (x: the last publication's estimate), averaged per coordinate over change_window_s
  /// (exponential), against that average's own long-run RMS (time constant change_baseline_s); when
  /// max_c |mean_c| / rms_c > change_threshold the data
  /// the estimate holds are discounted to change_keep of their weight (discountRecursiveLs) and the estimate
  /// re-converges from the new data. Armed change_hold_s after the start and after each detection. <= 0: off.
  double change_threshold = 12.0;  // no-change maxima 4.1-6.4, a 3 kg payload 19 (docs/estimator.md)
  double change_window_s = 0.25;
  double change_baseline_s = 10.0;
  double change_hold_s = 2.0;
  double change_keep = 1e-3;
  /// Effects of an `exoid diagnose` sidecar (estimator::readEffects; docs/estimator.md "Extra columns"). Each
  /// dynamics effect (viscous, coulomb, stribeck, offset, armature) is one extra parameter after the base
  /// parameters, column estimator::effectColumns at the sample's state, prior 0 with one-sigma
  /// effect_prior_factor x |sidecar value| + 1e-6; a gain corrects the torque sensor's part of y
  /// (correctMeasurement); a delay is refused (it needs the torque's future). Empty: the rigid model alone.
  EffectSet effects;
  double effect_prior_factor = 10.0;
  /// The torque sensors' calibration as nuisance parameters (docs/estimator.md, "Sensor offsets and gains"): per
  /// joint an offset column (1 on the joint's row; prior 0, one-sigma sensor_offset_sigma N m) and a gain column
  /// (the joint's measured torque; prior 0, one-sigma sensor_gain_sigma, relative), after the sidecar's columns;
  /// <= 0: that group is left out. Without them a sensor's offset and gain error go into the inertial parameters,
  /// whose estimate then claims a CoM height it does not know (torque_sensor_bias: the controller's k = 3 trust
  /// rule let 0.65 mm RMS of height error through, 0.05 with them). Standing still, an offset, a gain and a link's
  /// gravity torque are nearly the same column: with them the CoM directions they share keep the uncertainty the
  /// data leave them. A sensor's error is not a torque on the robot: never fed forward. A joint whose sample has
  /// has_tau false gets zero columns (their parameters stay at the prior). At a detected change their information
  /// is kept (the sensors did not change). Assumed: a strain-gauge joint sensor calibrated to a few % whose zero
  /// drifts by up to ~1 N m (0.7 % of the 150 N m drives' range) between calibrations.
  double sensor_offset_sigma = 1.0;
  double sensor_gain_sigma = 0.05;
  /// A body moves on the base link on its own: a wearer's trunk on its compliant lumbar joint (docs/estimator.md,
  /// "A body that moves on the base"). The rigid model lumps it into the base link, and when the pelvis rotates or
  /// accelerates the body lags; the base rows then misread the base link's first moment along its z (the CoM
  /// height: +27 mm at 20 sigma on a 75 kg wearer) while the covariance claims to know it. What the lag does to
  /// the horizontal CoM when the pelvis tilts is the same effective first moment, so the fit is kept, and true adds
  /// the prior's uncertainty of the height (the base link's mcz one sigma over the total mass, world z) to the
  /// published com_stddev: the controller's trust rule then leaves the height at the prior's and takes the
  /// horizontal CoM. Off for a robot without such a body (the empty exoskeleton: its payloads' heights come from
  /// those rows); `exoid experiment` turns it on for a scenario with a wearer, and a sidecar with
  /// EffectSet::base_body_moves (a diagnosis that named an unmeasured body on the base) does too.
  bool base_body_moves = false;
  /// Where each sole stands on its plate: the sole frame's origin minus the plate's reported sensor origin, lab axes,
  /// m ([0] right, [1] left; exo_estimator --sole-on-plate). The base position, and so every base moment row, rests
  /// on it: a common 1 cm not declared moved the estimate's CoM, and with it fed back the robot's, by 9.3 mm
  /// (docs/estimator.md "Where the soles stand"). Not in the checkpoint: a restart takes the value it is given.
  std::array<Eigen::Vector3d, 2> sole_on_plate{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
};

/// What happened to one input message.
enum class InputStatus { Accepted, NonFinite, OutOfOrder, Duplicate, Malformed };

class OnlineEstimator {
 public:
  /// prior_phi [p]: the prior (and the model the tau_correction is relative to: model.phi).
  OnlineEstimator(const Model& model, const BaseParameters& base, const Eigen::VectorXd& prior_phi,
                  const OnlineEstimatorOptions& options);
  bool ok() const { return error_.empty(); }
  const std::string& error() const { return error_; }

  /// One message of a tick (any order within the tick). Rejected (counted, state untouched): wrong sizes, a
  /// tick equal to (duplicate) or before (out of order) the channel's last accepted one, then the gate's value
  /// rules (sample_checks.hpp, as fromLcm's): non-finite values; a non-unit quaternion or a torque where
  /// has_tau is false (malformed).
  /// A tick is processed once its state and both plates are in; a tick left incomplete by a newer one is
  /// dropped (it shows up as missing). Allocation-free.
  InputStatus addState(const RobotStateSample& state);
  InputStatus addPlate(const ForcePlateSample& plate);

  /// Samples folded in since the last fillOutput().
  long samplesSincePublication() const { return since_publication_; }
  /// Sizes `out` (params, stddevs, tau_correction, residuals); call once before publish.
  void sizeOutput(EstimatorOutputSample& out) const;
  /// Solves and fills `out` (see docs/estimator.md for each field). utime is left to the caller.
  /// Allocation-free once `out` is prepared.
  void fillOutput(EstimatorOutputSample& out);
  /// True when the publication just made is one whose standard parameters reconcile() should make consistent.
  bool reconcileDue() const;
  /// Physically consistent standard parameters that reproduce the base estimate (docs/estimator.md,
  /// "Consistent standard parameters"): phi_c = argmin over consistent phi of
  ///     ||N^T Sigma^-1/2 (phi - phi_prior)||^2 + (B phi - x)^T A (B phi - x)
  /// (the prior's part that no base parameter informs, plus the base misfit in the estimate's information metric;
  /// without the constraint its minimiser is the conditional mean), by the batch WLS-RC-PC solver
  /// (solveConsistent: log-Cholesky per body, damped Newton), warm-started from the previous phi_c. Then
  /// `consistent` = every link of phi_c passes the pseudo-inertia test and its misfit ratio is within
  /// consistent_tolerance. Updates out.params, out.consistent and out.valid of the publication
  /// just made (call after publish). Allocates (a few ms): call it at a low rate, never per sample.
  void reconcile(EstimatorOutputSample& out);
  /// reconcile() in three steps, so that the solve can run on another thread while samples keep arriving
  /// (exo_estimator does): begin (copies what the solve needs), solve (reads only the job and const members:
  /// thread-safe against addState/addPlate/publish), finish (adopts phi_c; applies from the next publication).
  struct ReconcileJob {
    Eigen::MatrixXd U;     ///< [m x m] Cholesky factor of the information
    Eigen::VectorXd x, start, phi;  ///< [m] base estimate; [p] start; [p] result
    bool links_ok = false, done = false;
    int iterations = 0;
  };
  bool beginReconcile(ReconcileJob& job) const;
  void solveReconcile(ReconcileJob& job) const;
  void finishReconcile(const ReconcileJob& job);
  double misfitChi2() const { return chi2_; }   ///< (B phi - x)^T A (B phi - x) of the last publication's phi
  double misfitRatio() const { return ratio_; } ///< sqrt(misfitChi2 / RSS_w) of the last publication
  long reconciles() const { return reconciles_; }
  int lastReconcileIterations() const { return reconcile_iterations_; }

  /// Checkpoint (estimator structure, accumulated information, carried block information, counters): written to
  /// PATH.tmp and renamed. load refuses another estimator's checkpoint or a damaged file, leaving the state as
  /// it was. The differencing history and the filter are not saved: they restart on the next ticks.
  bool saveCheckpoint(const std::string& path, std::string* error) const;
  bool loadCheckpoint(const std::string& path, std::string* error);

  // Inspection (tests, tools).
  const RecursiveLsModel& rlsModel() const { return rls_model_; }
  const RecursiveLsData& rlsData() const { return rls_; }
  /// The row weighting in effect (options.row_weighting; Fixed under selective forgetting).
  RowWeighting rowWeighting() const { return weighting_; }
  /// [m + ne] after publish: base parameters, the sidecar's effects, the sensor offsets and gains (per joint)
  const Eigen::VectorXd& baseEstimate() const { return rls_.x; }
  int baseParameterCount() const { return m_base_; }   ///< m: the rigid model's base parameters
  int effectColumnCount() const { return ne_ - n_offset_; }  ///< the sidecar's columns (0 without one)
  /// The sensor columns: njoints offsets (sensor_offset_sigma > 0), then njoints gains (sensor_gain_sigma > 0).
  int sensorOffsetColumnCount() const { return n_offset_; }
  const Eigen::VectorXd& params() const { return phi_; }           ///< [p] after publish
  const Eigen::VectorXd& baseStddev() const { return rls_.sigma; } ///< [m] after publish
  const Eigen::VectorXd& priorBaseStddev() const { return prior_sigma_; }  ///< [m + ne] sqrt(diag Lambda0^-1)
  const Eigen::MatrixXd& priorInformation() const { return rls_model_.prior_information; }
  /// Last filtered equations handed to the update (tick, [K | E] [nv x (p + ne)], y [nv], gains corrected); valid
  /// when lastRowTick() >= 0.
  long lastRowTick() const { return row_tick_; }
  /// The state reconstructed for the last row (tick lastRowTick()): q, v, a and the base's motion it was built from.
  const State& lastState() const { return state_; }
  const Eigen::MatrixXd& lastK() const { return Kf_; }
  const Eigen::VectorXd& lastY() const { return yf_; }
  long incompleteTicks() const { return assembly_.counts().incomplete; }
  long changesDetected() const { return changes_; }      ///< residual-triggered discounts so far
  long lastChangeTick() const { return last_change_tick_; }  ///< tick of the last one (-1: none)
  double largestChangeStatistic() const { return z_max_; }   ///< largest max_c |mean_c| / rms_c while armed
  long rejected(InputStatus why) const;
  /// Correlation time of the residuals (samples per independent one; the largest coordinate's), last publication.
  double residualCorrelation() const { return correlation_; }
  /// Covariance of the published CoM (world axes), last uncertainty publication.
  const Eigen::Matrix3d& comCovariance() const { return com_cov_; }

 private:
  struct Raw {  // one tick's sensor values, ready for differencing
    long tick = 0;
    Eigen::VectorXd q, tau;
    Eigen::VectorXd sensed;  ///< [njoints] 1 where the joint has a torque sensor (has_tau), else 0
    Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
    Eigen::Vector3d gyro = Eigen::Vector3d::Zero(), acceleration = Eigen::Vector3d::Zero();
    ExternalWrench contact[2];
    Eigen::Vector3d plate_position[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    Eigen::Matrix3d foot_rotation[2] = {Eigen::Matrix3d::Identity(), Eigen::Matrix3d::Identity()};  ///< R_bf(q)
  };
  // Set-up (the constructor's stages, in order); each failure sets error_ and returns false.
  struct BasePrior;
  void setError(const std::string& what);
  /// The model (floating base, feet, soles) and the options' ranges.
  bool checkModelAndOptions();
  /// The prior on the base parameters, Lambda0 = (B Sigma B^T)^-1, and the recursive LS model on it.
  bool setUpRecursiveLs(const BaseParameters& base, const Eigen::VectorXd& prior_phi, BasePrior& prior);
  /// Appends extra columns (per column: the row it touches, its prior sigma, whether tau_correction adds it) to the
  /// recursive LS and to effect_sigma, ff_effect_, effect_row_, ne_; their count, or -1 (error set).
  int appendColumns(const std::vector<int>& rows, const std::vector<double>& sigma,
                    const std::vector<unsigned char>& feedforward, std::vector<double>& effect_sigma);
  /// The sidecar's dynamics effects as extra columns (prior 0, sigma = factor x |value| + 1e-6).
  bool addEffectColumns(std::vector<double>& effect_sigma);
  /// The sensor columns after them: an offset per joint, then a gain per joint (never fed forward).
  bool addSensorOffsetColumns(std::vector<double>& effect_sigma);
  /// phi = phi_prior + G (x - x0) with G = Sigma B^T Lambda0, its variance floor, and reconcile()'s prior rows.
  void initStandardParameters(const BaseParameters& base, const Eigen::VectorXd& prior_phi, const BasePrior& prior,
                              const std::vector<double>& effect_sigma);
  void sizeWorkspace();  ///< every per-sample buffer, so that the loop does not allocate
  // fillOutput()'s stages, in order:
  /// WLS-R online: each row's weight 1 / sigma_c from the previous solve's residuals over the whole memory;
  /// per independent sample: 1 / (sigma_c sqrt(T_c)) from the full-information fit's.
  void updateRowWeights();
  /// At a detected change (before the discount): R_, r_ scaled by change_keep like the data, then the sensor
  /// columns' marginal information of the last solve added back (their offsets and gains did not change).
  void carrySensorInformation();
  /// RowWeighting::WlsRCorrelated: the data at full weight (WLS-R weights from its own previous residuals) solved
  /// first; its residuals, what no parameter explains, give sigma_c and T_c. Measured against the published
  /// estimate instead, a parameter the data have not yet moved (an undeclared viscous damping) makes the
  /// residual correlated, which lowers its rows' weight, which keeps it from moving.
  void fitFullInformation();
  /// WLS-R's weight of row c, 1 / sigma_c, from the last solve's residual RMS (floored at 1e-6 of y_c's RMS).
  double wlsRWeight(int c) const;
  /// Residual RMS and effective samples over the estimate's memory (selective: earlier blocks carried).
  void reportResidualRms(bool selective, EstimatorOutputSample& out) const;
  /// phi and its stddev (recomputed when `uncertainty`) into out.params, param_stddev, base_params, base_stddev.
  void standardParameters(bool uncertainty, EstimatorOutputSample& out);
  /// Fraction of the base parameters whose variance the data cut to 1 / (1 + excited_gain) of the prior's.
  double excitation() const;
  /// The conditional mean if every link is consistent, else the last reconcile()'s phi_c judged by its misfit.
  bool judgeConsistency(bool solved, EstimatorOutputSample& out);
  /// out.tau_correction = K(q, 0, 0) (phi_hat - phi_model) + the sidecar's non-armature effects.
  void feedforwardTorque(EstimatorOutputSample& out);
  /// out.com_stddev, mass_stddev, tau_correction_stddev: the uncertainty of what the controller uses, computed
  /// when `uncertainty` (kept between), after feedforwardTorque (its kinematics and K) (com_uncertainty.cpp).
  void controllerUncertainty(bool uncertainty, EstimatorOutputSample& out);
  /// Per-sample: the innovations' long batch means, for the residuals' correlation time. e [nv].
  void trackResidualCorrelation(const Eigen::VectorXd& e);
  /// row_correlation_ [nv] and correlation_ from the batch means (floor: the row filter's).
  void rowCorrelationTimes();
  /// AT_ = Lambda0 + sum_c T_c g_c^4 sigma_c^2 D_c (upper): the data's information scaled by the correlation.
  void sandwichInformation();
  InputStatus admit(int channel, long tick, SampleFault values, bool sizes_ok, int* slot);
  void processReleased();  // every tick the assembly releases: complete ones are processed
  void assemble(int held, long tick);  // a complete tick's messages -> the ring
  void process();
  void fold();  // Selective: forgetting step and new block
  std::vector<double> effectSignature() const;  // the sidecar as the checkpoint records it
  std::string describeEffects(const std::vector<double>& signature) const;

  const Model& model_;
  OnlineEstimatorOptions opt_;
  std::string error_;
  int feet_[2] = {-1, -1};
  std::vector<DatasetOptions::Foothold> footholds_;
  double dt_ = 1e-3;

  RecursiveLsModel rls_model_;
  RecursiveLsData rls_;
  int m_base_ = 0, ne_ = 0;     ///< base parameters; extra columns after them (the sidecar's, then the offsets)
  int n_offset_ = 0;            ///< the sensor columns (offsets, then gains), the last n_offset_ of the ne_
  double height_prior_sigma_ = 0.0;  ///< base_body_moves: the prior's one sigma of the CoM height (m), else 0
  bool effects_ = false;        ///< a sidecar is applied (columns and/or gains)
  std::vector<unsigned char> ff_effect_;  ///< [ne] the column enters tau_correction (all but armature)
  std::vector<int> effect_row_;           ///< [ne] the coordinate (joint row) column e touches
  Eigen::MatrixXd Kx_;          ///< [nv x (p + ne)] [K | E] of the sample (only with extra columns)
  Eigen::VectorXd tau_sensor_;  ///< [nv] the torque sensors' part of y (gain correction)
  CausalRowFilter filter_;
  Eigen::VectorXd phi_;         ///< [p] standard parameters of the last publication
  /// The row weighting in effect: opt_.row_weighting, but Fixed under selective forgetting (row_weighting's doc).
  RowWeighting weighting_ = RowWeighting::Fixed;
  Eigen::VectorXd initial_weights_;  ///< [nv] the weights the estimator was built with (checkpoint structure)
  Eigen::VectorXd x_model_;     ///< [m] B phi_model: tau_correction = K_B (x - x_model)
  Eigen::VectorXd phi_prior_;   ///< [p]
  Eigen::MatrixXd G_;           ///< [p x m] phi = phi_prior + G (x - x0), G = Sigma Bt Lambda0
  Eigen::VectorXd phi_var0_;    ///< [p] diag(Sigma - G B Sigma): what no base parameter can tell
  Eigen::VectorXd prior_sigma_; ///< [m]
  Eigen::MatrixXd GC_;          ///< [p x m] workspace
  Eigen::VectorXd param_stddev_;  ///< [p] of the last uncertainty computation

  // Consistent standard parameters (reconcile()).
  Eigen::MatrixXd B_;           ///< [m x p] base map
  Eigen::MatrixXd prior_rows_;  ///< [(p - m) x p] N^T Sigma^-1/2: the prior where no base parameter looks
  Eigen::VectorXd prior_rows_rhs_;  ///< [p - m] prior_rows_ phi_prior
  Eigen::VectorXd phi_c_, d_, u_m_;  ///< [p] consistent parameters; [m] misfit workspaces
  bool have_phi_c_ = false, links_ok_ = false, valid_rest_ = false;
  double chi2_ = 0.0, ratio_ = 0.0;
  long reconciles_ = 0;
  int reconcile_iterations_ = 0;
  /// chi2_ = (B phi_c - x)^T A (B phi_c - x) (A = U^T U, the last solve's factor) and ratio_ against the weighted
  /// residual cost over the memory from the residual RMS `rms` [nv]; true when within the tolerance. Allocation-free.
  bool misfit(const Eigen::VectorXd& rms, double effective_samples);

  // Selective forgetting: information carried from earlier blocks (R_ and r_ also hold the sensor columns' kept
  // information after a detected change).
  // Carried information [mx x mx], [mx] (added to every solve): selective forgetting's earlier blocks, and the
  // sensor columns' information kept through a detected change (carrySensorInformation).
  Eigen::MatrixXd R_, dD_, R1_, Y_, M_;
  Eigen::MatrixXd sensor_S_;  ///< [n_offset x n_offset] workspace of carrySensorInformation
  Eigen::VectorXd r_, dd_, u_, mask_;
  Eigen::LLT<Eigen::MatrixXd> mllt_;
  Eigen::VectorXd rss_carry_;   ///< [nv] forgotten-weighted residual sum of squares of earlier blocks
  double n_carry_ = 0.0;        ///< its sample weight
  long block_samples_ = 0;
  long publications_ = 0;

  // Tick assembly (tick_assembly.hpp) with window 0: a newer tick closes the older one as incomplete, so two
  // slots (the tick being assembled and a newer one arriving) hold every message.
  static constexpr int kSlots = 2;
  TickAssembly assembly_{(1u << kTickState) | (1u << kTickPlateRight) | (1u << kTickPlateLeft), 0, kSlots};
  RobotStateSample slot_state_[kSlots];
  ForcePlateSample slot_plate_[kSlots][2];
  std::vector<Raw> raw_;        ///< [2L + 1] ring of the last ticks (L: the larger half window in use)
  Eigen::Matrix<double, 3, Eigen::Dynamic> sg_, sg_gyro_;  ///< [3 x 2L + 1] fit weights (value, slope per tick,
                                                           ///< curvature), zero outside each one's own window;
                                                           ///< sg_gyro_ only with base_rate_from_legs off
  int raw_count_ = 0, raw_head_ = 0;
  long rejected_[5] = {0, 0, 0, 0, 0};

  // Per-sample workspace.
  Data kin_, fk_;               ///< the sample's kinematics and regressor; the newest tick's feet (base rate)
  State state_, ff_state_, fk_state_;
  bool has_state_ = false;
  Eigen::VectorXd y_, yf_;
  Eigen::MatrixXd Kf_;
  long row_tick_ = -1;
  long since_publication_ = 0;
  Eigen::VectorXd dx_;

  // Change detection (options change_*): per-coordinate innovation mean over the window and mean square over the
  // baseline, samples since the detector was (re)armed, detections.
  void detectChange(long tick);
  /// The innovation of the filtered sample of `tick` against the last publication, then its consumers.
  void observeInnovation(long tick);
  Eigen::VectorXd innovation_, innovation_mean_, innovation_ms_;  ///< [nv]
  long change_samples_ = 0, changes_ = 0, last_change_tick_ = -1;
  double z_max_ = 0.0;
  double ms_weight_ = 0.0;  ///< 1 - (1 - a)^n: the weight the baseline's samples have since the (re)arming
  static constexpr double kCorrelationWindowS = 2.0;  ///< batch-means window: >> the 2 Hz filter's ~0.25 s

  // Uncertainty of what the controller uses (controllerUncertainty): the residuals' correlation (per coordinate:
  // long-window mean of the innovation, that mean's mean square, the innovation's mean square), the right-hand
  // sides and the sandwich's information.
  static constexpr double kMinWeightedVariance = 1e-12;  ///< floor of g_c^2 sigma_c^2 (a noise-free row)
  Eigen::VectorXd corr_mean_, corr_ms_, corr_var_;  ///< [nv]
  Eigen::VectorXd row_correlation_;  ///< [nv] T_c, samples per independent residual (>= 1)
  // The full-information fit (fitFullInformation): its estimate and WLS-R weights, and the
  // innovation of each sample against it.
  Eigen::VectorXd x_full_;                                          ///< [m]
  Eigen::VectorXd full_weight_, full_innovation_;                   ///< [nv]
  double correlation_ = 1.0;         ///< max_c T_c of the last publication
  double filter_correlation_ = 1.0;  ///< the row filter's, for white residuals (filterCorrelationTime)
  Eigen::MatrixXd V_, AV_;  ///< [mx x (4 + nv)] A^-1 F and A_T A^-1 F
  Eigen::MatrixXd AT_;      ///< [mx x mx] upper
  Eigen::Matrix3d com_cov_ = Eigen::Matrix3d::Zero();  ///< world frame, of the last uncertainty publication
  Eigen::Vector3d com_stddev_ = Eigen::Vector3d::Zero();
  double mass_stddev_ = 0.0;
  Eigen::VectorXd tau_stddev_;  ///< [nv]
  bool have_trust_ = false;

};

}  // namespace exoid::estimator
