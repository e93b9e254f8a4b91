#pragma once
// The stages of the diagnosis (diagnose.hpp, docs/diagnose.md), each on the constant model and options and one
// scratch DiagnoseData (Pinocchio's f(const Model&, Data&, inputs)). diagnose() is the thin driver that calls them
// in this order:
//   declaredColumns -> trainingPass -> declaredFit -> profileCoulombWidths -> profileElasticScales
//   -> declaredPrediction -> rowWeights
//   -> candidateSignals -> { foldFactors -> selectEffects [per step: currentFits -> screenCandidates ->
//   screenPayloads -> selectStep] -> finalFit -> relinearise }* (Gauss-Newton on the gain and delay signals)
//   -> residualSeries -> summarizeCoordinates -> residualPredictability -> describeFindings.
// Sizes: nv rows per sample, nj joints, md declared columns (m after dropping the unexcited ones), nc candidate
// columns, npl payload links (4 columns each), P = m + nc + 4 npl + 1 columns of the full problem (the last: y),
// F = options.folds time-block folds. The stages are exposed for their tests; callers use diagnose().
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/estimator/batch/lsq_factor.hpp"
#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/model.hpp"

namespace exoid::estimator {

/// A candidate column: an effect kind on one joint (coordinate row `coord`).
struct DiagnosisCandidate {
  EffectKind kind;
  int joint;
  int coord;
  double width;   ///< Coulomb, Stribeck: the joint's profiled width (0: the shape's); ElasticExp(Coupled): its scale
  double center;  ///< the elastic kinds: the mean training angle (rad) of the joint the signal reads
  int coupled;    ///< the coupled kinds: the neighbour joint whose angle the signal reads; -1 otherwise
  double ratio = 0.0;           ///< ElasticExpCoupled: the profiled ratio r
  double coupled_center = 0.0;  ///< ElasticExpCoupled: the neighbour's mean training angle
};

/// The effect a candidate stands for, with the value `value`.
inline Effect candidateEffect(const DiagnosisCandidate& cd, double value) {
  Effect e{cd.kind, cd.joint, value, cd.width, cd.center, cd.coupled};
  e.ratio = cd.ratio, e.coupled_center = cd.coupled_center;
  return e;
}

/// Per-sample signals of one segment, [n x nv] unless noted.
struct SegmentSignals {
  long n = 0;
  std::vector<double> t;       ///< [n] s
  Eigen::MatrixXd ext, dext;   ///< y minus the torque sensors' part (the plates' contribution), d/dt of it
  Eigen::MatrixXd v, a;        ///< [n x nj] joint velocity (K's fv column), acceleration (d/dt of v)
  Eigen::MatrixXd q;           ///< [n x nj] joint position (segments with Segment::stream_state; else empty)
  Eigen::MatrixXd base;        ///< [n x 6] floating base: alpha, s (ResidualSeries::base); else empty
  Eigen::MatrixXd y, tau0;     ///< measured y, the declared model's prediction
  Eigen::MatrixXd tau, dtau;   ///< reference prediction of the gain/delay signals (Gauss-Newton), d/dt of it
};

/// One joint's sums for the Coulomb-width profile over the grid of nw widths: signals s = [Coulomb per width,
/// Stribeck per width, v] (ns2 + 1 = 2 nw + 1), K_j the joint's row of the declared columns.
struct WidthProfileSums {
  Eigen::MatrixXd B;            ///< [md x (ns2 + 1)] K_j^T s
  Eigen::VectorXd cc, cy, cv;   ///< [ns2 + 1] s^T s, s^T y_j, s^T v
};

/// One joint's sums for the elastic-scale profile over the grid of ne scales: signals z = [s (exp((q - q_ref) / s) - 1)
/// per scale, q - q_ref, 1] (ne + 2; q_ref: the joint's first training angle), K_j the joint's row of the declared columns.
struct ElasticProfileSums {
  Eigen::MatrixXd B;   ///< [md x (ne + 2)] K_j^T z
  Eigen::MatrixXd G;   ///< [(ne + 2) x (ne + 2)] z^T z
  Eigen::VectorXd zy;  ///< [ne + 2] z^T y_j
  double qsum = 0.0;   ///< sum of q over the training samples (the center is its mean)
  long n = 0;
};

/// One (joint j, neighbour c) pair's sums for the ElasticExpCoupled profile over the grid of ns scales x nr ratios:
/// signals z = [s (exp(x / s) - 1) per (s, r), x = (q_j - q_ref,j) + r (q_c - q_ref,c); q_j - q_ref,j; q_c - q_ref,c; 1]
/// (nz = ns nr + 3). Each grid signal is scored beside the last three only, so only those products are kept.
struct CoupledElasticProfileSums {
  int joint = -1, coupled = -1;
  Eigen::MatrixXd B;   ///< [md x nz] K_j^T z
  Eigen::MatrixXd G;   ///< [nz x 4] z^T [z_k, the three linear signals]: column 0 z_k^T z_k, columns 1-3 z^T (x_j, x_c, 1)
  Eigen::VectorXd zy;  ///< [nz] z^T y_j
};

/// The fits of the current model (columns S) on each training factor f = 0..F (F: all folds; f < F: all but f).
struct CurrentFits {
  int ns = 0;                                  ///< |S|
  std::vector<Eigen::MatrixXd> Q, Rs, A;       ///< [F+1]: thin Q [P x ns], R [ns x ns] of A = Rtrain[f](:, S)
  std::vector<Eigen::VectorXd> xs, ry;         ///< [F+1]: solution [ns], residual of y [P]
  Eigen::MatrixXd sse_now;                     ///< [F x nv] held-out weighted SSE per (fold, coordinate)
  double dof_res = 0.0;                        ///< measured rows - ns - 1
};

/// One-sided tests over the F folds that the held-out reductions d [F] lie above 0: the paired t-test (F - 1 degrees of
/// freedom) and Wilcoxon's signed-rank test, p = 2 min(p_t, p_W); mean = d's mean, t_stat the t-test's statistic.
void pairedTest(const Eigen::VectorXd& d, int F, double& mean, double& t_stat, double& p_value);

/// A single candidate column scored in one selection step.
struct CandidateEval {
  int c = -1;                 ///< candidate index
  double gain = 0.0;          ///< mean over the folds of the pooled held-out weighted SSE reduction
  bool admissible = false;    ///< admissibleValue of the training estimate
  double separable = 0.0;     ///< fraction of the column outside the current columns' span
  double jackknife_se = 0.0;  ///< delete-one-fold jackknife standard error of the value
  Eigen::VectorXd fold_gains; ///< [folds] the held-out reduction of each fold (gain is their mean)
  Finding f;
};

/// A payload candidate (4 columns of one link) scored in one selection step.
struct PayloadEval {
  int l = -1;  ///< index into DiagnoseData::plinks
  double gain = 0.0;
  bool admissible = false;
  PayloadFinding f;
};

/// Scratch of one diagnosis: filled stage by stage.
struct DiagnoseData {
  std::vector<const Segment*> segments;  ///< training first, then validation
  size_t ntrain = 0;
  int nv = 0, nj = 0, p = 0;
  // Declared columns (indices into K), their (coordinate, column) excitation, the payload links.
  std::vector<int> decl;
  int md = 0, m = 0;
  std::vector<std::vector<char>> touched;  ///< [nv][md, then m] a row's declared column is ever non-zero
  std::vector<int> plinks;
  int npl = 0;
  std::vector<std::vector<char>> ptouch;   ///< [nv][npl] row r can see link l's payload
  std::vector<SegmentSignals> caches;      ///< [segments]
  TriangularFactor declared_factor;        ///< [md + 1] of [K_decl | y] over the training rows
  std::vector<double> widths;              ///< the Coulomb width grid
  int nw = 0;
  std::vector<WidthProfileSums> profile;   ///< [nj]
  std::vector<int> keep;                   ///< excited declared columns (indices into the first md)
  Eigen::MatrixXd A_keep;                  ///< [(md + 1) x m] their columns of the declared factor
  Eigen::VectorXd x0;                      ///< [m] the declared model's OLS fit
  std::vector<double> width_of;            ///< [2 nj] profiled width of each joint's Coulomb, Stribeck candidate
  bool has_q = false;                      ///< every segment streams q (Segment::stream_state): elastic kinds testable
  std::vector<double> q_ref;               ///< [nj] the first training sample's q (reference of the profile's signals)
  std::vector<ElasticProfileSums> eprofile;  ///< [nj] (has_q only)
  std::vector<double> center_of, scale_of; ///< [nj] each joint's mean training angle, profiled ElasticExp scale
  std::vector<CoupledElasticProfileSums> cprofile;  ///< [pairs] (joint, kinematic neighbour), has_q only
  std::vector<double> cscale_of, cratio_of;         ///< [pairs] profiled ElasticExpCoupled scale and ratio
  Eigen::VectorXd sigma, rows0;            ///< [nv] row weight 1/sigma's sigma, measured training rows
  long total_rows = 0;
  std::vector<DiagnosisCandidate> cands;
  int nc = 0, P = 0, iy = 0, pc0 = 0;      ///< columns: declared, candidates, payloads (from pc0), y (iy)
  std::vector<std::vector<int>> active;    ///< [nv] P-space columns of each coordinate's rows
  bool measurement_cands = false;          ///< a gain or delay candidate is tested
  // Selection state.
  std::vector<int> S;                      ///< P-space columns of the current model
  Eigen::VectorXd xa;                      ///< [|S|] the final (unweighted) fit
  std::vector<TriangularFactor> fc;        ///< [F x nv] weighted per-(fold, coordinate) factors over `active`
  std::vector<Eigen::MatrixXd> Rfold, Rtrain;  ///< [F], [F+1] P x P: per fold; all but fold f (F: all)
  std::vector<int> fcol, pcol;             ///< P-space column of each accepted effect / first of each payload
  std::vector<char> pdone;                 ///< [npl] payload accepted or not testable
  std::vector<char> excluded;              ///< [nc] not separable in this pass
  int steps_done = 0;
  bool selecting = true;

  const Segment& segment(size_t s) const { return *segments[s]; }
  /// Segment::held_base: that segment's unmeasured rows are zero rows (K, y and every candidate signal), not data.
  bool unmeasured(const Model& model, size_t s, int r) const { return !segmentRowMeasured(model, segment(s), r); }
};

/// Position of P-space column `col` in the current model's columns data.S (the index into data.xa).
int columnPosition(const std::vector<int>& S, int col);
/// The column of K behind P-space payload column c (pc0 <= c < iy): the link's m, mcx, mcy or mcz.
int payloadParameter(const Model& model, const DiagnoseData& data, int c);

/// Central differences of the columns of x [n x k] over (possibly jittering) times t [n]; one-sided at the ends.
Eigen::MatrixXd centralDifference(const std::vector<double>& t, const Eigen::MatrixXd& x);

/// Coordinate names (out.coordinate_names), the declared columns (the structural base parameters, with the fv, fc
/// columns only when declared, without the rigid-body ones when held) and the payload links (held model only).
void declaredColumns(const Model& model, const DiagnoseOptions& opt, const std::vector<Segment>& train,
                     const std::vector<Segment>& validate, DiagnoseData& data, DiagnosisResult& out);
/// Pass A (training segments): the factor of [K_decl | y], the excitation of every (coordinate, column), t, v, y and
/// y - tau_sensor per sample, and per joint the width-profile sums and (data.has_q) the elastic-profile sums. False
/// with *error on a stream error, a sample of the wrong size or a segment of fewer than 3 samples.
bool trainingPass(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out,
                  std::string* error);
/// Excited declared columns (column-pivoted QR of the factor's unit-norm columns, threshold 1e-8) and the declared
/// OLS fit x0 = argmin ||K_decl x - y||. False when none is excited or fewer rows than columns remain.
bool declaredFit(DiagnoseData& data, DiagnosisResult& out, std::string* error);
/// Per joint and dry-friction kind, the grid width whose signal s, beside v, removes the most of the declared fit's
/// training residual e: max over w of g^T M^-1 g, M the Gram of [s_w v] orthogonal to the declared columns, g = their
/// products with e (data.width_of; the one width without a grid).
void profileCoulombWidths(DiagnoseData& data);
/// Per joint, the ElasticExp scale (opt.elastic_scales) whose signal s, beside q and a constant, removes the most of the
/// declared fit's training residual e (the same projected gain g^T M^+ g as the Coulomb widths', over [s, q, 1]: with
/// the constant beside it the score does not depend on the signal's reference angle), and the joint's center, its mean
/// training angle (data.center_of, data.scale_of; nothing without q).
void profileElasticScales(const DiagnoseOptions& opt, DiagnoseData& data);
/// Per (joint, kinematic neighbour) pair, the ElasticExpCoupled (scale, ratio) of the grid whose signal, beside both
/// angles and a constant, removes the most of the declared fit's training residual (the same score as
/// profileElasticScales'; data.cscale_of, data.cratio_of). After profileElasticScales (the centers).
void profileCoupledElasticShapes(const DiagnoseOptions& opt, DiagnoseData& data);
/// Pass B (every segment): the declared model's prediction tau0 = K_decl x0 and its d/dt; the validation segments'
/// t, v, y; q where the segment streams it (data.has_q: every segment does); a floating base's motion (alpha, s).
/// False on a stream error or data that changed between two reads.
bool declaredPrediction(const Model& model, DiagnoseData& data, DiagnosisResult& out, std::string* error);
/// Row weights: sigma_c = sqrt(SSE_c / rows_c) of the declared model's training residual per coordinate (WLS-R,
/// thesis eqs. 29-32), floored at 1e-9 max sigma.
void rowWeights(const Model& model, DiagnoseData& data);
/// The candidate columns (opt.kinds x joints; no gain without a torque sensor, no viscous/Coulomb when declared, no
/// elastic kind without q; the elastic ones with the joint's center and profiled scale) and the active P-space columns
/// of each coordinate.
void candidateSignals(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out);
/// Candidate cd's signal at sample i of segment s (effectSignal; gain and delay on the sensor's part of the
/// reference prediction); 0 on an unmeasured row.
double candidateSignal(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data, size_t s, long i,
                       const DiagnosisCandidate& cd);
/// Pass C (training): per-(fold, coordinate) factors of the weighted rows [K_decl | candidates | payloads | y] / sigma_c
/// over the active columns (sample i in fold floor((t_i - t_0) / chunk_seconds) mod F), then Rfold [F] and Rtrain
/// [F + 1] in P-space.
bool foldFactors(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, std::string* error);
/// R [P x P] of the coordinate factors (fold, coordinate) in `which` scattered into P-space; unweight: times sigma_c.
Eigen::MatrixXd mergeFoldFactors(const DiagnoseData& data, const std::vector<std::pair<int, int>>& which, bool unweight);
/// The current model's fits (columns data.S) on every training factor and their held-out weighted SSE per
/// (fold, coordinate): ||R_{f,c} [x_f; -1]||^2 over the coordinate's active columns.
void currentFits(const DiagnoseOptions& opt, const DiagnoseData& data, CurrentFits& fits);
/// Screening of the single candidate columns against the current fit: training estimate, separable share, the
/// held-out gain per fold d_f (refit without fold f), the one-sided tests that the d_f lie above 0 (the paired
/// t-test, t = mean / (sd / sqrt F), and Wilcoxon's signed-rank test; p = 2 min(studentTUpperTail(t, F - 1),
/// signedRankUpperTail(d))), the jackknife error. Candidates inside the current
/// span are excluded (in step 0 recorded in out.first_step as not separable).
std::vector<CandidateEval> screenCandidates(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data,
                                            const CurrentFits& fits, int step, DiagnosisResult& out);
/// Candidate c's held-out test (pairedTest's p; fold gains d [F]) against the current model with the columns `given`
/// (indices into the columns, data.m + a candidate; linearly independent of the model's) added first: does c still
/// predict the held-out folds with those effects in? data.S is restored. Selection asks it of a coupling given the
/// effects on the joint whose angle it reads.
double conditionalCandidateTest(const DiagnoseOptions& opt, DiagnoseData& data, int c, const std::vector<int>& given,
                                Eigen::VectorXd& d);
/// Screening of the payload candidates (a link's 4 columns m, m c at once, a rank-4 update of the current fit), tested
/// like the single columns; admissible: mass above 3 jackknife errors and CoM within payload_com_bound.
std::vector<PayloadEval> screenPayloads(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data,
                                        const CurrentFits& fits, int step, DiagnosisResult& out);
/// What one selection step did.
enum class StepOutcome { Stop, Effect, Payload, PayloadRelinearise };
/// The step's decision: the Bonferroni test (alpha / tested) decides whether a coordinate has an effect, the held-out
/// gain which kind (a refinement only by refinement_margin over the kind it refines); a significant payload with a
/// larger gain wins.
/// Records the first step's scores (step 0) and appends the accepted column(s) to data.S and out.
StepOutcome selectStep(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data,
                       const std::vector<CandidateEval>& evals, const std::vector<PayloadEval>& pevals, int step,
                       DiagnosisResult& out);
/// Forward selection from data.steps_done on (up to max_effects steps): true when a payload was accepted while gain
/// or delay candidates are tested (the caller relinearises, then selection goes on).
bool selectEffects(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out);
/// Final fit of the accepted columns: values from the unweighted OLS (data.xa), standard errors from the weighted
/// problem's covariance s^2 (R^T R)^-1; the payloads' mass and CoM from the final values.
void finalFit(const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out);
/// New Gauss-Newton reference on every segment: tau = K (the augmented model's rigid part, payloads included), dtau.
bool relinearise(const Model& model, DiagnoseData& data, std::string* error);
/// Pass D (every segment): residual before (y - tau0) and after (the augmented model) per sample (out.series).
bool residualSeries(const Model& model, const DiagnoseOptions& opt, DiagnoseData& data, DiagnosisResult& out,
                    std::string* error);
/// Per coordinate: held-out and training RMS before/after, the noise floor sqrt(mean(diff(r)^2) / 2), lag-1
/// autocorrelations, the best-correlated candidate; the pooled RMSEs.
void summarizeCoordinates(const Model& model, const DiagnoseOptions& opt, const DiagnoseData& data,
                          DiagnosisResult& out);
/// The report's words: payload candidates absorbed without a held model, one sentence per payload and finding.
void describeFindings(const Model& model, const DiagnoseOptions& opt, DiagnosisResult& out);

}  // namespace exoid::estimator
