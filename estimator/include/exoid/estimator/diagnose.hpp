#pragma once
// Diagnosis of what a rigid-body model leaves out (docs/diagnose.md): identify the declared model, analyse
// the residual per generalized coordinate, test a library of candidate effects per joint as extra regressor
// columns (or, for a torque-sensor gain error and a time delay, as a linearised correction of the
// measurement), choose them by forward selection with paired tests over held-out time-block folds, and
// re-identify with the accepted effects.
//
// Data come as segments (runs) that stream their rows (K [nv x p], y [nv]) on request, so the diagnosis
// works on anything the dataset pipeline produces (measured CSV, LCM log) and never holds W or y whole:
// each pass keeps per-(fold, coordinate) triangular factors of [W_declared | candidate columns | y] and a
// few per-sample signals (t, v, the declared model's prediction), O(samples x nv) doubles.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/residual_predictability.hpp"
#include "exoid/estimator/unmeasured_body.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// Candidate effects on one joint. The column is the effect's signal on that joint's row of W (zero
/// elsewhere); the coefficient is the effect's value (unit in effectUnit).
enum class EffectKind {
  Viscous,    ///< signal v (rad/s); value fv, N m s/rad
  Coulomb,    ///< signal tanh(v / width); value fc, N m (width: the effect's own, else the shape's coulomb_width)
  Stribeck,   ///< signal tanh(v / width) exp(-(v / stribeck_velocity)^2); value fs - fc, N m
  Offset,     ///< signal 1; value: constant torque (sensor offset or gravity-independent load), N m
  Armature,   ///< signal a (rad/s^2, dv/dt); value: rotor inertia reflected through the gear, kg m^2
  GainError,  ///< measured = (1 + g) model: signal = the declared model's torque-sensor part; value g (fraction)
  Delay,      ///< measured(t) = model(t - d): signal = -d/dt of that torque-sensor part; value d, s
  /// signal q - center (rad; center: the effect's reference angle, the training data's mean posture); value k,
  /// N m/rad (>= 0): a spring about a rest angle, k (q - q0) = k (q - center) + k (center - q0), the constant
  /// part being an offset (separable from one because q varies)
  Elastic,
  /// signal s (exp((q - center) / s) - 1), s = width (rad, signed: > 0 stiffens toward +q, < 0 toward -q); value k,
  /// N m/rad (>= 0), the stiffness at center: the exponential shape of passive tissue (Riener & Edrich 1999)
  ElasticExp,
  /// signal q_c - center on joint j's row, c = Effect::coupled a kinematic neighbour of j; value N m/rad (either sign):
  /// a biarticular spring, the moment on j that depends on the neighbour's angle (a muscle across both joints)
  ElasticCoupled,
  /// signal s (exp(x / s) - 1), x = (q_j - center) + r (q_c - coupled_center), s = width, r = ratio, c = Effect::coupled
  /// a kinematic neighbour of j; value k, N m/rad (>= 0), the stiffness about j at the two centers: the exponential
  /// of passive tissue whose exponent a biarticular muscle makes a sum of two angles, as in every term of Riener &
  /// Edrich's law (the hip's exp(1.3403 - 0.0226 phi_K + 0.0305 phi_H): s = 0.57 rad, r = -0.74 on the knee). Over a
  /// knee swing of 1.3 rad the neighbour changes that term's stiffness e^1.7 times, which neither the joint's own
  /// exponential nor a linear coupling spans. Refines ElasticExp (r = 0).
  ElasticExpCoupled,
};
inline constexpr int kEffectKinds = 11;
/// "viscous", "coulomb", "stribeck", "offset", "armature", "gain", "delay", "elastic", "elastic_exp", "elastic_coupled",
/// "elastic_exp_coupled"
const char* effectKindName(EffectKind k);
const char* effectKindWords(EffectKind k);  ///< "viscous friction", ..., "time delay", "joint elasticity", ...
const char* effectUnit(EffectKind k);       ///< "N m s/rad", "N m", "N m", "N m", "kg m^2", "", "s", "N m/rad", "N m/rad"
bool parseEffectKind(const std::string& name, EffectKind& k);
/// Gain error and delay act on the measurement (identify corrects y), the others add dynamics columns.
bool isMeasurementEffect(EffectKind k);
/// Coulomb and Stribeck: signals tanh(v / width) (...), the kinds an Effect's width applies to.
bool isDryFriction(EffectKind k);
/// Elastic, ElasticExp, ElasticCoupled and ElasticExpCoupled: signals of joint positions about the effect's center.
bool isElastic(EffectKind k);
/// ElasticCoupled and ElasticExpCoupled: signals that read a neighbour's angle (Effect::coupled).
bool isCoupled(EffectKind k);
/// The kind a refinement kind refines (Stribeck: Coulomb; ElasticExp: Elastic; ElasticExpCoupled: ElasticExp); k itself
/// otherwise. A refinement is named only when it predicts the held-out data clearly better than the kind it refines
/// (DiagnoseOptions).
EffectKind refinedKind(EffectKind k);
/// The physical family of a kind, for telling whether two findings are different explanations: every elastic kind is
/// Elastic (a spring, whatever its shape or angle), Stribeck is Coulomb (dry friction); every other kind its own.
EffectKind effectFamily(EffectKind k);
/// s: the largest time delay the linearised column -d dtau/dt stands for. tau(t - d) = tau(t) - d dtau/dt + O(d^2 w^2):
/// at the ~1 Hz of the motions the second-order term reaches 5 % of the first at 50 ms; a larger fitted "delay" is some
/// other slow structure borrowing the column (KUKA lwr_6: 324 ms), not a delay.
inline constexpr double kMaxLinearisedDelay = 0.05;
/// Physically admissible value: friction, armature and stiffness are >= 0, a delay within +-kMaxLinearisedDelay, the
/// others may have either sign.
bool admissibleValue(EffectKind k, double value);

/// Shape constants of the smooth friction signals (documented in docs/diagnose.md and written to the sidecar).
struct EffectShape {
  double coulomb_width = 0.03;      ///< rad/s: tanh(v / width) reaches 0.76 at |v| = width
  double stribeck_velocity = 0.1;   ///< rad/s: the static-friction excess decays as exp(-(v / vs)^2)
  double center = 0.0;              ///< rad: the elastic kinds' reference angle (one effect's: effectShape)
  double elastic_scale = 0.0;       ///< rad, signed: ElasticExp's and ElasticExpCoupled's s (effectShape); 0: linear
};

/// Signal of an effect at one sample of its joint (see EffectKind): q the angle the signal reads (effectAngle: the
/// joint's own, a neighbour's, or ElasticExpCoupled's sum of both), v, a the joint's velocity and acceleration,
/// tau_model the model torque and dtau_model its d/dt.
double effectSignal(EffectKind k, const EffectShape& shape, double q, double v, double a, double tau_model,
                    double dtau_model);

struct Effect {
  EffectKind kind = EffectKind::Offset;
  int joint = -1;      ///< model joint index
  double value = 0.0;  ///< in effectUnit(kind)
  /// Coulomb and Stribeck: this effect's tanh width, rad/s (the diagnosis fits it per joint; 0: the set's
  /// shape.coulomb_width). ElasticExp: the exponential's signed scale s, rad (fitted per joint; never 0).
  double width = 0.0;
  double center = 0.0;  ///< rad, the elastic kinds: the reference angle of the signal q - center
  /// ElasticCoupled: the model joint whose angle the signal is; ElasticExpCoupled: the joint whose angle enters the
  /// exponent beside the effect's own (a kinematic neighbour of joint); -1 otherwise
  int coupled = -1;
  double ratio = 0.0;           ///< ElasticExpCoupled: r, the neighbour's angle's weight in the exponent (rad/rad)
  double coupled_center = 0.0;  ///< ElasticExpCoupled: rad, the neighbour's reference angle
};

/// The joint whose angle an effect's signal reads: Effect::coupled for the coupled kinds (ElasticExpCoupled reads its
/// own joint's too), else the effect's own joint.
inline int signalJoint(const Effect& e) { return isCoupled(e.kind) ? e.coupled : e.joint; }

/// The angle effectSignal takes for effect e, rad, from its joint's angle q_joint and the neighbour's q_coupled
/// (q[signalJoint(e)]): q_coupled for ElasticCoupled, q_joint + r (q_coupled - coupled_center) for ElasticExpCoupled
/// (the signal subtracts the center), q_joint otherwise.
inline double effectAngle(const Effect& e, double q_joint, double q_coupled) {
  if (e.kind == EffectKind::ElasticCoupled) return q_coupled;
  if (e.kind == EffectKind::ElasticExpCoupled) return q_joint + e.ratio * (q_coupled - e.coupled_center);
  return q_joint;
}

/// The shape an effect's signal uses: `shape` with the effect's own Coulomb width, center and scale where it has them.
EffectShape effectShape(const EffectShape& shape, const Effect& effect);

/// Receives one sample: time (s), K [nv x p] (columns of Model::phi), y [nv], and tau_sensor [nv]: the joint
/// torque sensors' part of y (tools::streamFileRows / DatasetBuilder::sensorTorque(); = y where y is the sensor
/// torque itself, a fixed base). The gain and delay candidates act on that part only: on the exoskeleton y_j
/// also holds the plate wrenches mapped through the leg, which no sensor gain scales.
using DiagnosisRowSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                            const Eigen::VectorXd& tau_sensor)>;
/// DiagnosisRowSink plus the joint positions q [njoints] the row was computed from.
using DiagnosisStateSink = std::function<void(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y,
                                              const Eigen::VectorXd& tau_sensor, const Eigen::VectorXd& q)>;
/// One run: streams all its samples, in time order, to the sink; must give the same rows every call.
struct Segment {
  std::string name;
  std::function<bool(const DiagnosisRowSink& sink, std::string* error)> stream;
  /// A run with the pelvis held by a harness (tools::SourceOptions::held_base): its rows that are not measured
  /// (heldBaseRowMeasured) come as zero rows; they add nothing to the fits and are left out of the row weights
  /// and of every residual figure.
  bool held_base = false;
  /// Optional: `stream` with the joint positions q [njoints] behind each row (tools::streamFileStateRows). The last
  /// stage (residual predictability) builds its dictionary from q; without it, only from v, a and their history.
  std::function<bool(const DiagnosisStateSink& sink, std::string* error)> stream_state = nullptr;
};

/// Memory shared by the segments kept in it (keptInMemory): what they may hold together, and hold now.
struct RowMemory {
  size_t budget_bytes = 0;
  size_t used_bytes = 0;
};

/// The segment, its first complete pass kept in `memory` and every later pass replayed from there, bit for bit: per
/// sample t, K [nv x p], y [nv], tau_sensor [nv] and, where the segment has stream_state, q [njoints] (8 (nv (p + 2)
/// + njoints + 1) bytes: 17.0 kB on the exoskeleton, 323 MB for a 19 s run at 1 kHz). The diagnosis passes over each
/// run four times (screening, selection, the report's residuals, the online comparison), and reading, filtering and
/// regressing a log was half of its time. A pass that would take the memory over its budget stops keeping (what it
/// kept is freed) and that segment is read from its source every time, as without it; so is one whose source fails
/// or changes its rows' sizes. The first pass reads through stream_state where there is one (the same rows plus q).
Segment keptInMemory(Segment source, const std::shared_ptr<RowMemory>& memory);

/// Whether row `row` of the segment's samples is data: every row, except the unmeasured ones of a held-base segment
/// (heldBaseRowMeasured), which come as zero rows.
inline bool segmentRowMeasured(const Model& model, const Segment& segment, int row) {
  return !segment.held_base || heldBaseRowMeasured(model, row);
}

struct DiagnoseOptions {
  /// The elastic kinds need the joint positions: they are tested only when every segment has Segment::stream_state.
  /// ElasticExpCoupled is not tested unless named here (`exoid diagnose --effects`): on a wearer's calibration swing it
  /// named the ankles' knee coupling as one term but added wrong names elsewhere (docs/diagnose.md "Two-angle
  /// exponential").
  std::vector<EffectKind> kinds = {EffectKind::Viscous,   EffectKind::Coulomb,    EffectKind::Stribeck,
                                   EffectKind::Offset,    EffectKind::Armature,   EffectKind::GainError,
                                   EffectKind::Delay,     EffectKind::Elastic,    EffectKind::ElasticExp,
                                   EffectKind::ElasticCoupled};
  EffectShape shape;
  /// rad/s: the Coulomb widths tried per joint. Dry friction's apparent width differs from joint to joint (how
  /// slowly the joint moves, how long it sticks, how the filter smears the sign change): each joint's Coulomb and
  /// Stribeck candidates take the width whose signal, beside v, would remove the most of that joint's
  /// declared-model residual on the training data (a least-squares profile over this grid, docs/diagnose.md;
  /// empty: shape.coulomb_width for every joint).
  std::vector<double> coulomb_widths = {0.001, 0.002, 0.005, 0.01, 0.02, 0.03, 0.04, 0.05, 0.07, 0.1};
  bool declared_friction = false;  ///< the declared model includes the fv, fc columns of every joint
  int folds = 20;                  ///< time-block folds for the held-out test
  double chunk_seconds = 0.25;     ///< the training data are cut into chunks of this length, dealt to the
                                   ///< folds in turn (chunk i -> fold i mod folds), so every fold spans the run
  double alpha = 0.01;             ///< family-wise false-alarm rate per selection step (Bonferroni)
  double min_explained = 0.02;     ///< an effect must remove this fraction of its joint's held-out residual
  /// A refinement (refinedKind: Stribeck's static excess of Coulomb friction, the exponential spring of the linear
  /// one) is named instead of the kind it refines on a joint only when its held-out gain exceeds that kind's by more
  /// than this fraction (at the low speeds and small excursions of balancing the two columns nearly coincide).
  double refinement_margin = 0.1;
  /// rad, signed: the ElasticExp scales tried per joint (the one whose signal, beside q, explains the most of the
  /// declared model's training residual on the joint's row is tested; docs/diagnose.md).
  std::vector<double> elastic_scales = {-0.4, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.4};
  /// rad, signed, and rad/rad: the ElasticExpCoupled grid, scale s x ratio r, profiled per (joint, neighbour) like
  /// the scales (beside the joint's own and the neighbour's angle and a constant), when kinds has ElasticExpCoupled.
  /// Riener & Edrich's terms span s 0.12-0.68 rad and r -0.2 to -1.3 (docs/diagnose.md); the grid covers either sign
  /// of both. Empty: not tested.
  std::vector<double> coupled_elastic_scales = {-0.8, -0.4, -0.2, -0.1, 0.1, 0.2, 0.4, 0.8};
  std::vector<double> coupled_elastic_ratios = {-2.0, -1.4, -1.0, -0.7, -0.5, -0.35, -0.25, -0.125,
                                                0.125, 0.25, 0.35, 0.5, 0.7, 1.0, 1.4, 2.0};
  int max_effects = 30;
  double torque_noise = -1.0;      ///< known torque noise sigma (N m) for the size check; < 0: estimated
  /// The declared model's rigid-body parameters are held, not identified: the caller streams y - K phi_declared
  /// (`exoid diagnose --declared-model URDF`; tools::SourceOptions::held_phi), so no rigid-body column is fitted
  /// (the fv, fc columns still are with declared_friction). A change of the robot (a payload) then shows in the
  /// residual instead of moving the identified parameters.
  bool hold_declared = false;
  /// Payload candidates (docs/diagnose.md "Payload"): per moving link, a rigid body fixed to it, its mass and first
  /// moment (4 columns: the link's m, mcx, mcy, mcz columns of K; its own rotational inertia is not fitted). Tested
  /// only with hold_declared: otherwise the identified link parameters absorb it (reported as not separable).
  bool payload = true;
  /// m: an admissible payload has a mass above 3 of its (jackknife) standard errors and its CoM within this distance
  /// of its link frame's origin.
  double payload_com_bound = 0.5;
  /// A payload candidate with less than this share of some direction of its 4 columns outside the current model's
  /// span is not tested: next to an accepted payload on a neighbouring link of the same chain it is mostly a
  /// re-distribution of the same load between the two links (KUKA: 0.0094 and 0.00056 beside the flange's), whose
  /// split the data decide by their model error, not by the load.
  double payload_min_separable = 0.05;
  /// The last stage: is the augmented model's residual predictable from the state? (residual_predictability.hpp;
  /// its test uses alpha and min_explained.)
  PredictabilityOptions predictability;
  /// The stage that asks whether an unmeasured body moves on the floating base on a spring (unmeasured_body.hpp; its
  /// test uses alpha and min_explained).
  UnmeasuredBodyOptions unmeasured_body;
};

/// A rigid body the data say is fixed to one link (a payload): mass m > 0 and CoM c in the link frame, from the
/// fitted first moment m c (docs/diagnose.md "Payload").
struct PayloadFinding {
  int link = -1;                       ///< model body index
  double mass = 0.0, mass_se = 0.0;    ///< kg; standard error: delete-one-fold jackknife over the time-block folds
  Eigen::Vector3d com = Eigen::Vector3d::Zero(), com_se = Eigen::Vector3d::Zero();  ///< m, link frame
  double explained = 0.0;  ///< fraction of the held-out-fold residual of the rows it moves that it removed
  double p_value = 1.0, t_stat = 0.0;
  double separable = 0.0;  ///< smallest fraction of a direction of its 4 columns outside the span of the model's
  int tested = 0;          ///< candidates tested in its step (Bonferroni factor)
  std::string status;      ///< first step: like CandidateScore::status; findings: "accepted"
  std::string sentence;
};

/// One accepted effect.
struct Finding {
  Effect effect;
  double std_error = 0.0;  ///< standard error of the value (training fit, white-noise assumption: optimistic)
  double explained = 0.0;  ///< fraction of its joint's held-out-fold residual it removed when added
  double p_value = 1.0;    ///< one-sided test over the folds: 2 min(t-test, signed-rank) (before the step's Bonferroni)
  double t_stat = 0.0;
  int tested = 0;          ///< candidates tested in its step (Bonferroni factor)
  /// Another kind of effect on the same coordinate that the data do not tell from this one (effectFamily differs; it
  /// competed in the same step and the paired test that this finding's held-out fold gains exceed its own failed at
  /// alpha): the report names both, this one first. A hip's torque while standing is mostly the gravity moment of what
  /// it carries, so a torque-sensor gain and a spring on its angle can be nearly one signal (docs/diagnose.md).
  /// For a coupled kind (a moment on this joint from joint k's angle) the alternative may also be k's strongest
  /// candidate (alternative.joint is then k) where, with every candidate on k in the model, this finding's held-out
  /// test is not significant (separation_p is then that test's p): the identified link parameters carry what an
  /// effect on k leaves in k's rows into this joint's row, as a function of k's angle (selection.cpp).
  bool ambiguous = false;
  Effect alternative;             ///< value: its training estimate when added instead of this finding
  double alternative_std_error = 0.0;
  double alternative_gain = 0.0;  ///< its mean held-out gain over this finding's (above 1 where a refined kind lost to
                                  ///< the coarser one within refinement_margin, or for an effect on a coupling's
                                  ///< angle's joint)
  double separation_p = 1.0;      ///< one-sided p of the paired test that this finding predicts better than it (an
                                  ///< alternative on another joint: this finding's test with k's candidates in)
  std::string sentence;    ///< the finding in words
};

/// A candidate as scored in the first selection step (against the declared model alone).
struct CandidateScore {
  Effect effect;            ///< value: the training estimate when added alone
  double correlation = 0.0; ///< correlation of the declared model's residual with the signal (training)
  double explained = 0.0;   ///< held-out-fold fraction of its joint's residual removed
  double p_value = 1.0;
  /// Fraction of the candidate's (weighted, training) signal outside the span of the declared model's columns:
  /// only this part can show in the residual. Near 0: these motions cannot tell the effect from a change of the
  /// rigid-body parameters (a constant torque on a balancing robot is a first-moment shift of its links), at any size.
  double separable = 0.0;
  /// Standard error of its value when added alone: the delete-one-fold jackknife over the time-block folds (honest
  /// for a residual correlated over less than a chunk, as filtered data are; infinite when not separable). A small
  /// separable share still shows an effect above 3 standard errors when the data are many and well spread (a
  /// calibration run's torque offsets: ~1 % separable, yet a few hundredths of a N m).
  double std_error = 0.0;
  std::string status;       ///< "accepted", "not significant", "below min-explained", "inadmissible value",
                            ///< "not separable from the declared model"
};

/// Residual analysis of one coordinate.
struct CoordinateSummary {
  std::string name;
  int joint = -1;                    ///< -1 for a floating base row
  double rms_before = 0.0, rms_after = 0.0;              ///< held-out (validation segments; else training)
  double train_rms_before = 0.0, train_rms_after = 0.0;  ///< training
  double noise_floor = 0.0;   ///< torque_noise if given, else sqrt(mean(diff(r)^2) / 2) of the validation residual
  double lag1_before = 0.0, lag1_after = 0.0;  ///< lag-1 autocorrelation of the residual (white noise: ~0)
  double best_correlation = 0.0;               ///< largest |correlation| with a candidate signal, before
  /// which candidate that is (its kind and shape: width or scale, center, neighbour; the value unset)
  Effect best_candidate;
};

/// Per-sample residuals of one segment (for plots and reports).
struct ResidualSeries {
  std::string segment;
  bool validation = false;
  Eigen::VectorXd t;              ///< [n]
  Eigen::MatrixXd before, after;  ///< [n x nv] y - prediction of the declared / augmented model
  Eigen::MatrixXd v, a;           ///< [n x nj] joint velocity (from K's fv column) and acceleration (dv/dt)
  Eigen::MatrixXd tau_model;      ///< [n x nv] declared model's prediction
  Eigen::MatrixXd q;              ///< [n x nj] joint positions (segments with Segment::stream_state; else empty)
  /// [n x 6] floating base: its angular acceleration alpha (rad/s^2) and specific force s = a_b - R^T g (m/s^2), base
  /// coordinates, read off the base link's own columns of K (docs/conventions.md); empty for a fixed base
  Eigen::MatrixXd base;
  bool held_base = false;         ///< Segment::held_base
};

struct DiagnosisResult {
  std::vector<std::string> coordinate_names;  ///< [nv]
  int declared_columns = 0;      ///< base-parameter columns of the declared model kept (excited)
  int dropped_columns = 0;       ///< structural base columns the training data did not excite
  int candidates = 0;            ///< candidate columns tested
  long train_samples = 0, validation_samples = 0;
  bool has_validation = false;
  std::vector<Finding> findings;  ///< in the order they were accepted
  std::vector<CandidateScore> first_step;
  std::vector<CoordinateSummary> coordinates;  ///< [nv]
  double pooled_before = 0.0, pooled_after = 0.0;              ///< held-out RMSE over all coordinates
  double train_pooled_before = 0.0, train_pooled_after = 0.0;
  std::vector<ResidualSeries> series;  ///< one per segment, training first
  std::vector<PayloadFinding> payloads;             ///< accepted payloads, in the order accepted (values: final fit)
  std::vector<PayloadFinding> payload_first_step;   ///< every link's payload candidate in the first step
  PredictabilityResult predictability;  ///< the last stage, on the residual after augmentation
  UnmeasuredBodyResult unmeasured_body;  ///< the base rows' resonance test, on the residual after augmentation
};

/// The diagnosis loop. train: at least one segment; validate: may be empty (then "held-out" numbers are the
/// training ones and only the fold test guards the choice). False with *error if a segment fails to stream,
/// the segments disagree in size with the model, or the training data cannot identify the declared model.
bool diagnose(const Model& model, const std::vector<Segment>& train, const std::vector<Segment>& validate,
              const DiagnoseOptions& options, DiagnosisResult& out, std::string* error);

/// One-sided p-value P(T >= t) of Student's t with dof degrees of freedom (Boost.Math); 1 for a NaN t or dof <= 0.
double studentTUpperTail(double t, double dof);

/// One-sided p-value of Wilcoxon's signed-rank test that the values d [n] lie above 0: P(W+ >= w+) under the null of
/// signs independent and equally likely given the magnitudes, W+ the sum of the ranks (1 = smallest |d|) of the
/// positive values; exact (a count over the 2^n sign patterns, O(n^3)). Ties in |d| share their mean rank; zeros are
/// left out (they carry no sign). 1 with no nonzero value or a non-finite one.
double signedRankUpperTail(const Eigen::VectorXd& d);

/// The augmented model's sidecar (docs/diagnose.md): YAML with the shape constants and one entry per effect.
struct EffectSet {
  std::string model;  ///< URDF file name the effects belong to
  EffectShape shape;
  std::vector<Effect> effects;
  /// The diagnosis named an unmeasured body on the floating base (UnmeasuredBodyResult: a plane found). The online
  /// estimator given this sidecar then keeps the prior's uncertainty on the CoM height
  /// (OnlineEstimatorOptions::base_body_moves): such a body's lag reads as a higher base link in the base rows
  /// (docs/estimator.md "A body that moves on the base").
  bool base_body_moves = false;
};
bool writeEffects(const std::string& path, const Model& model, const EffectSet& set, std::string* error);
/// Reads a sidecar; fails naming the entry on an unknown joint or kind or a non-finite value.
bool readEffects(const std::string& path, const Model& model, EffectSet& set, std::string* error);

/// The sidecar's dynamics effects (viscous, coulomb, stribeck, offset, armature) as extra regressor columns,
/// one per effect in the sidecar's order (measurement effects have none): the same effectSignal the diagnosis
/// tested, on the effect's joint row, zero elsewhere. The coefficient of column e is effect e's value.
int effectColumnCount(const EffectSet& set);
/// E [nv x effectColumnCount(set)] at one sample: q, v, a [njoints] joint position, velocity and acceleration (the
/// dataset's, e.g. v from the regressor's fv column and a its time derivative). Allocation-free.
void effectColumns(const Model& model, const EffectSet& set, const Eigen::Ref<const Eigen::VectorXd>& q,
                   const Eigen::Ref<const Eigen::VectorXd>& v, const Eigen::Ref<const Eigen::VectorXd>& a,
                   Eigen::Ref<Eigen::MatrixXd> E);
/// A sidecar applied to streamed rows as known corrections (`exoid identify --effects`): every dynamics effect's
/// torque value x signal is subtracted from its joint's row of y (v from K's fv column, a its central time
/// difference, one-sided at the ends, as in the diagnosis), then correctMeasurement. Rows leave one sample late;
/// finish() emits the last. Construct with a set without delay (check correctMeasurement first).
class EffectCorrector {
 public:
  EffectCorrector(const Model& model, const EffectSet& set, RowSink sink);
  /// tau_sensor: the torque sensors' part of y (DatasetBuilder::sensorTorque()); y itself when omitted. q: the joint
  /// positions [njoints] behind the row (DatasetBuilder::jointPosition()), which the elastic kinds need: a set with
  /// one refuses rows without q (add returns false); zeros otherwise.
  bool add(double t, const Eigen::MatrixXd& K, const Eigen::VectorXd& y, const Eigen::VectorXd* tau_sensor = nullptr,
           const Eigen::VectorXd* q = nullptr);
  void finish();

 private:
  void emit(double t_next, const Eigen::VectorXd& v_next);
  const Model& model_;
  EffectSet set_;
  RowSink sink_;
  bool pending_ = false, has_prev_ = false;
  double t_ = 0.0, t_prev_ = 0.0;
  Eigen::MatrixXd K_, E_;
  Eigen::VectorXd y_, tau_, q_, v_, v_prev_, a_;
  bool needs_q_ = false;
};

/// The online estimator with and without the sidecar's columns (issue 9 item 4), offline: the training rows fed sample
/// by sample through RecursiveLs (no forgetting, prior = the URDF +-25 %, the effects' prior 0 with sigma 10 x their
/// value; gains corrected on the sensor part of y), then its torque prediction on the validation rows, back in
/// measured units. Both see the same rows, so the difference is the sidecar alone. Runs (out.ran) only with validation
/// data and an effect, and not with a held declared model (the rows then hold y - K phi_declared, not what the online
/// estimator sees). res: the diagnosis of train/validate (its series give v, a per row).
struct OnlineComparison {
  bool ran = false;
  double before = -1.0, after = -1.0;              ///< joint-row RMSE on the validation rows, N m
  Eigen::VectorXd joint_before, joint_after;       ///< [njoints] per joint
};
bool compareOnline(const Model& model, const DiagnoseOptions& options, const std::vector<Segment>& train,
                   const std::vector<Segment>& validate, const DiagnosisResult& res, const EffectSet& set,
                   OnlineComparison& out, std::string* error);

/// Measurement effects on y [nv]: a torque-sensor gain g makes the sensor's part tau_j of its joint's row
/// tau_j / (1 + g) (y_j += tau_j / (1 + g) - tau_j); tau_sensor [nv] = that part (DatasetBuilder::sensorTorque();
/// y itself for a fixed base, as the three-argument form assumes). A delay needs the future of the signal:
/// false (y untouched) if the set holds one. Allocation-free.
bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y,
                        const Eigen::Ref<const Eigen::VectorXd>& tau_sensor);
bool correctMeasurement(const Model& model, const EffectSet& set, Eigen::Ref<Eigen::VectorXd> y);

}  // namespace exoid::estimator
