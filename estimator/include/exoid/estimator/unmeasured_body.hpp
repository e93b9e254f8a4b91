#pragma once
// A stage of the diagnosis (docs/diagnose.md "Does an unmeasured body move on the base?"): does a body that no sensor
// measures move on the floating base? The wearer's trunk on its compliant lumbar joint is the case it is for: it puts
// a wrench on the pelvis that only the base rows see (joint effects cannot act there), and that a rigid model reads
// as other inertial parameters. Two signatures are tested per plane (sagittal: rows base_ny, base_fx; frontal:
// base_nx, base_fy; base coordinates), each on held-out data.
//
// 1. The gravity signature: whatever moves the body (the base, its own muscles, a reflex), an unmeasured mass whose
//    first moment moves by p(t) = m d(t) (kg m, horizontal, base frame) adds to the base rows, linearised,
//        Delta f_x = p'',   Delta n_y = z p'' - g p                   (z: the height of the moving mass)
//    (frontal: Delta f_y = p_y'', Delta n_x = -z p_y'' + g p_y), so the first moment is the force row's double
//    integral and, whatever the body's mass or height, the moment row carries -g (frontal +g) times it:
//        J[f_x] = (z f_x - n_y) / g         (frontal: J[f_y] = (n_x + z f_y) / g),
//    J = 1 / (s + w0)^2 a leaky double integral (w0 = 2 pi x leak_hz), both rows through the same high-pass
//    s^2 / (s + w0)^2. A rigid model's parameter error or a plate force error gives n = L f (L about -0.9 m for a force
//    at the ground, below the base) and nothing of J[f]. Test: J[f] from [n, f, 1] against the null [f, 1]; a finding
//    needs n's coefficient with gravity's sign, reported as b / g (1 for a moving mass; the moment row's own noise
//    biases it low). J[f] is then the body's first-moment excursion (its RMS is reported, kg m).
// 2. The driven response: a body on a spring (mass m, CoM h above a pivot at h_p on the base's z axis, inertia J_p
//    about the pivot, spring k, damper c) leans phi from its rigid pose under the base's specific force s = a_b - R^T g
//    and angular acceleration alpha (the base link's own columns of K):
//        J_p phi'' + c phi' + (k - m g h) phi = -m h s_x - J_p alpha_y
//        Delta n_y = (J_p + h_p m h) phi'' - m g h phi,  Delta f_x = m h phi''
//    so phi is a second-order low-pass G(s) = w^2 / (s^2 + 2 z w s + w^2) (w^2 = (k - m g h) / J_p, 2 z w = c / J_p) of
//    the two inputs, and each row's extra wrench a linear combination of G[u], G'[u], u in {s_x, alpha_y}. Well below w
//    the body follows the base, G[u] ~ u - (2 z / w) u' - u'' / w^2: a change of the rigid parameters and a lead that
//    the rigid model (or a filter mismatch) can mimic. So the body's columns are tested beyond a null of the same
//    inputs through a fast filter F (10 Hz, damping 0.7) and their first two derivatives, and a constant: only the
//    resonance counts. The (frequency, damping) grid point with the smallest training SSE is the plane's resonance.
//
// Both on the diagnosis' base-row residual `after` (rows scaled by their training RMS), decimated to rate_hz after a
// warm-up of the filters:
//   - held-out predictions: contiguous training folds, each predicted from the others minus a guard of block_seconds
//     (a grid point chosen on them too), the validation segments from all training data; the null model alike;
//   - held-out blocks of block_seconds: the shares 1 - SSE / SSE(r) of both models; the gain g_b = SSE_null,b -
//     SSE_model,b, its share sum g_b / SSE(r) with a delete-one-block jackknife error, and the one-sided t-test of
//     mean g_b > 0 (blocks - 1 dof) at alpha / 4 (two signatures, two planes; Bonferroni).
// A plane is named when a signature passes its test with a gain of at least min_share (the gravity signature also with
// gravity's sign): "an unmeasured body moves on the base (sagittal plane: ...)", never a joint effect.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"

namespace exoid::estimator {

struct ResidualSeries;

struct UnmeasuredBodyOptions {
  bool enabled = true;
  /// Hz: natural frequencies tried, 0.5-4 Hz in steps of 2^(1/4) (a lightly damped resonance is narrow: a step of
  /// sqrt(2) missed one at 2.5 Hz, damping 0.2, in the tests). A body of 10-60 kg on a spring-damper of 1.5-10 x its
  /// own gravitational stiffness m g h at 0.2-0.4 m lands there (a trunk held by tissue and a trunk support:
  /// docs/wearer.md "Lumbar joint values"); a rigid attachment is far above it and a body that falls over has none.
  std::vector<double> frequencies_hz = {0.5, 0.59, 0.71, 0.84, 1.0, 1.19, 1.41, 1.68, 2.0, 2.38, 2.83, 3.36, 4.0};
  std::vector<double> damping_ratios = {0.1, 0.2, 0.35, 0.6};  ///< of critical: lightly to well damped
  double null_frequency_hz = 10.0;  ///< the driven null's fast filter F (damping 0.7): above every resonance tried
  double leak_hz = 0.2;             ///< w0 / 2 pi of the gravity signature's leaky double integral (below every resonance)
  double rate_hz = 50.0;            ///< regression samples per second (the filters run at the data's own rate)
  double warmup_seconds = 2.0;      ///< the filters' start (from rest at the first sample) is left out per segment
  /// s: held-out blocks and the guard around a held-out fold. Shorter than the last stage's 5 s: a 6-move run is ~19 s,
  /// and with a 5 s guard on each side a fold was predicted from a few seconds; the false-alarm rate at 2.5 s on noise
  /// correlated over 1 s is in docs/diagnose.md.
  double block_seconds = 2.5;
  int folds = 5;                    ///< contiguous training folds
};

/// One signature's held-out figures on one plane.
struct BodyTest {
  double share = 0.0, null_share = 0.0;  ///< 1 - SSE / SSE(r) of the model's and the null's predictions (scaled rows)
  double gain = 0.0, se = 0.0, p = 1.0;  ///< (SSE_null - SSE_model) / SSE(r), its jackknife SE, one-sided p
  double validation_share = 0.0, validation_gain = 0.0;  ///< on the validation segments only (0 without)
  int blocks = 0;
  bool passed = false;                   ///< p below the level, gain >= min_share (and admissible)
};

/// One plane's figures, on held-out data (cross-fitted training blocks and validation segments).
struct UnmeasuredBodyPlane {
  std::string plane;                   ///< "sagittal" or "frontal"
  std::string moment_row, force_row;   ///< coordinate names: "base_ny", "base_fx" / "base_nx", "base_fy"
  double moment_rms = 0.0, force_rms = 0.0;  ///< held-out RMS of the two rows' residual, N m and N
  /// The gravity signature: b / g with the plane's sign (a moving mass: 1; the moment row's noise biases it low), the
  /// height z of the moving mass (m, above the base origin), the first-moment excursion RMS of J[f] (kg m, training).
  BodyTest gravity;
  double gravity_ratio = 0.0, lever = 0.0, first_moment_rms = 0.0;
  /// The driven response (both rows): the resonance chosen on all training data; the model's share per row.
  BodyTest driven;
  double frequency_hz = 0.0, damping_ratio = 0.0;
  double moment_share = 0.0, force_share = 0.0;
  bool found = false;
  std::string verdict;   ///< "an unmeasured body" or, per signature, "not significant" / "below min-share" /
                         ///< "wrong sign" (the gravity coefficient against gravity's)
  std::string sentence;  ///< the finding in words (empty when not found)
};

struct UnmeasuredBodyResult {
  bool ran = false;
  double level = 0.0;  ///< per-test p threshold alpha / 4
  std::vector<UnmeasuredBodyPlane> planes;  ///< sagittal, frontal (a plane without data is left out)
  /// Held-out samples for plots: per segment t and per plane's two rows the residual and the driven response's and
  /// its null's predictions.
  struct Series {
    std::string segment;
    bool validation = false;
    Eigen::VectorXd t;                       ///< [n]
    /// [n x 4]: columns 2 p (moment row, N m) and 2 p + 1 (force row, N) of plane p (sagittal, frontal)
    Eigen::MatrixXd residual, body, null;
  };
  std::vector<Series> series;
};

/// The second-order response of the body to one input, at the input's own samples: x = G[u] and x' for
/// G(s) = w^2 / (s^2 + 2 z w s + w^2), w = 2 pi f, from rest at u[0] (x = u[0], x' = 0); u linear between samples,
/// fourth-order Runge-Kutta with steps of at most 0.1 / w. t [n] increasing, u [n]; x, dx resized to [n].
void secondOrderResponse(const Eigen::VectorXd& t, const Eigen::VectorXd& u, double f_hz, double zeta,
                         Eigen::VectorXd& x, Eigen::VectorXd& dx);

/// The stage on the diagnosis' per-sample residuals (ResidualSeries: t, after, base; held_base segments and a fixed
/// base give no rows). alpha, min_share: DiagnoseOptions::alpha, min_explained (the share of the plane's remaining
/// held-out residual a signature must predict beyond its null: BodyTest::gain). Nothing to test (no base rows) leaves
/// out.ran false.
bool unmeasuredBodyResponse(const Model& model, const std::vector<ResidualSeries>& series, double alpha, double min_share,
                            const UnmeasuredBodyOptions& options, UnmeasuredBodyResult& out, std::string* error);

}  // namespace exoid::estimator
