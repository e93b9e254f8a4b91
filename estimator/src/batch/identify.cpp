#include "exoid/estimator/batch/identify.hpp"

#include "exoid/estimator/batch/consistent.hpp"
#include "exoid/model/inertial.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

namespace exoid::estimator {

const char* rankRuleName(RankRule r) {
  switch (r) {
    case RankRule::Full: return "full";
    case RankRule::Fixed: return "fixed";
    case RankRule::Validation: return "validation";
    case RankRule::CrossValidation: return "cv";
    case RankRule::CrossValidation1Se: return "cv-1se";
    case RankRule::Jackknife: return "jackknife";
    case RankRule::Gcv: return "gcv";
  }
  return "?";
}

bool parseRankRule(const std::string& name, RankRule& r) {
  for (RankRule x : {RankRule::Full, RankRule::Fixed, RankRule::Validation, RankRule::CrossValidation,
                     RankRule::CrossValidation1Se, RankRule::Gcv, RankRule::Jackknife})
    if (name == rankRuleName(x)) return r = x, true;
  return false;
}

std::string methodLabel(Method m, bool pc) { return std::string(methodName(m)) + (pc ? "-PC" : ""); }

LinkVerdict checkLink(const std::string& name, const Eigen::Ref<const Eigen::Matrix<double, 10, 1>>& p) {
  const LinkConsistency c = checkConsistency(Vector10d(p));  // the pseudo-inertia test of model/inertial.hpp
  LinkVerdict v;
  v.name = name;
  v.mass = p[0];
  v.min_eigenvalue = c.min_eigenvalue;
  v.consistent = c.consistent;
  return v;
}

namespace {

/// The truncation rank z by the options' rule (capped at the numerical rank later); false (why) when the rule
/// cannot run on this data.
bool chooseRank(const LsqAccumulator& train, const Model& model, const Eigen::VectorXd& prior,
                const IdentifyOptions& o, const LsqAccumulator* validation, const ScaledProblem& sp,
                const LsqFactor& vfactor, const std::vector<const LsqAccumulator*>& processing, IdentifyResult& out,
                std::string& why) {
  const int m = train.baseColumns();
  switch (o.rank_rule) {
    case RankRule::Full: out.rank = out.numerical_rank; break;
    case RankRule::Fixed:
      if (o.rank < 0 || o.rank > m) return why = "--rank must be in [0, " + std::to_string(m) + "]", false;
      out.rank = o.rank;
      break;
    case RankRule::Validation:
      if (!validation) return why = "the validation rank rule needs validation data", false;
      out.curve = rankByValidation(sp, vfactor);
      out.rank = out.curve.best;
      break;
    case RankRule::CrossValidation:
    case RankRule::CrossValidation1Se:
      if (train.folds() < 2) return why = "cross-validation needs at least 2 folds", false;
      out.curve = rankByCrossValidation(train, model, prior, o.method,
                                        o.rank_rule == RankRule::CrossValidation ? CvRule::Minimum : CvRule::OneStandardError);
      out.rank = out.curve.best;
      break;
    case RankRule::Jackknife:
      if (train.folds() < 2) return why = "the jackknife needs at least 2 folds", false;
      out.curve = rankByJackknife(train, model, prior, o.method, o.prior_uncertainty, processing);
      out.rank = out.curve.best;
      break;
    case RankRule::Gcv:
      out.curve = rankByGcv(sp);
      out.rank = out.curve.best;
      break;
  }
  return true;
}

/// -PC: an estimate with an inconsistent link is replaced by the consistent solution at the same rank (rank 0:
/// the prior, made consistent).
void makePhysicallyConsistent(const Model& model, const ScaledProblem& sp, const IdentifyOptions& o,
                              IdentifyResult& out) {
  bool all = true;
  for (const LinkConsistency& c : checkConsistency(model, out.phi)) all = all && c.consistent;
  if (!all && out.rank == 0) {
    out.phi = projectConsistent(model, out.phi);  // nothing kept: the prior, made consistent
  } else if (!all) {
    ConsistentOptions co;
    co.max_iterations = o.consistent_iterations;
    const ConsistentResult pc = solveConsistentAtRank(model, sp, out.rank, 3e-2, 1e-6, co);
    out.consistent_iterations = pc.iterations;
    out.phi = pc.phi;
  }
  // The held function's parameter (its column is zero in the data: the solve left it at the prior) from the others.
  // It moves a first moment, which can put that body's CoM outside its inertia: its second moments are then raised
  // by the least isotropic amount that makes it consistent, which leaves every mass and first moment (and so the
  // held function, the total mass and the CoM) as they are. Carried instead as a heavy row of the consistent solve,
  // the function stalled Levenberg-Marquardt and traded mass between a wearer's links (docs/identification.md).
  if (o.held_function.j >= 0) {
    o.held_function.apply(out.phi);
    for (int b = 0; b < model.nbodies; ++b) {
      auto p = out.phi.segment<kParamsPerBody>(model.bodyParamIndex(b));
      if (checkConsistency(Vector10d(p)).consistent) continue;
      Eigen::Matrix4d J = pseudoInertia(p);
      const double m = J(3, 3);
      if (!(m > 0.0)) continue;  // no mass to hang the moments on: reported as inconsistent
      const Eigen::Vector3d h = J.topRightCorner<3, 1>();
      const Eigen::Matrix3d S = J.topLeftCorner<3, 3>() - h * h.transpose() / m;  // second moments about the CoM
      const Eigen::Vector3d eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S).eigenvalues();  // ascending
      const double lift = 1e-6 * std::max({std::abs(eig[0]), std::abs(eig[2]), 1e-9});
      J.topLeftCorner<3, 3>() += (lift - eig[0]) * Eigen::Matrix3d::Identity();
      p = paramsFromPseudoInertia(J);
    }
  }
}

/// Left at the prior: the estimate is the prior's value (the fill and WLS-RC-PC move parameters the kept
/// directions barely reach, so reach alone overstates what stayed). Weakly excited: the norm of the
/// parameter's (scaled) unit direction inside span(V_z) is small, yet it moved.
void classifyExcitation(const ScaledProblem& sp, const Eigen::VectorXd& prior, double excitation_threshold,
                        IdentifyResult& out) {
  for (int i = 0; i < static_cast<int>(prior.size()); ++i) {
    const double reach = out.rank > 0 ? sp.V.row(i).head(out.rank).norm() : 0.0;
    if (std::abs(out.phi[i] - prior[i]) <= 1e-9 * sp.fill[i]) out.unexcited.push_back(i);
    else if (reach < excitation_threshold) out.weakly_excited.push_back(i);
  }
}

/// Training RMSE (and the data's RMS) over `rows` equations; with validation data its RMSE, the prior's, per
/// coordinate, and the held-out ratio.
void reportFit(const LsqAccumulator& train, const LsqAccumulator* validation, const LsqFactor& vfactor,
               const Eigen::VectorXd& prior, const IdentifyOptions& o, long rows, IdentifyResult& out) {
  const int m = train.baseColumns(), nv = train.coordinates();
  {
    const Eigen::VectorXd xb = out.phi_base;
    double sse = 0.0, yy = 0.0;
    for (int c = 0; c < nv; ++c) sse += train.residual(c, xb), yy += train.residual(c, Eigen::VectorXd::Zero(m));
    out.training_rmse = std::sqrt(sse / rows);
    out.training_y_rms = std::sqrt(yy / rows);
  }
  if (!validation) return;
  out.validation_rmse = rmse(vfactor, out.phi);
  out.prior_validation_rmse = rmse(vfactor, prior);
  const Eigen::VectorXd xb = validation->base().base_map * out.phi;
  for (int c = 0; c < nv; ++c)
    out.validation_rmse_per_coordinate.push_back(std::sqrt(validation->residual(c, xb) / std::max<long>(1, validation->rows(c))));
  if (out.training_rmse > 0.0) {
    out.heldout_ratio = out.validation_rmse / out.training_rmse;
    out.data_differ = out.heldout_ratio > o.data_differ_ratio;
  }
}

}  // namespace

bool identify(const LsqAccumulator& train, const Model& model, const Eigen::VectorXd& prior,
              const IdentifyOptions& o, const LsqAccumulator* validation, IdentifyResult& out, std::string* error,
              const std::vector<const LsqAccumulator*>& processing) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  out = IdentifyResult();
  out.method = o.method;
  out.physically_consistent = o.physically_consistent;
  out.rank_rule = o.rank_rule;
  out.prior = prior;
  const int p = model.nparams(), m = train.baseColumns(), nv = train.coordinates();
  if (prior.size() != p) return fail("the prior has " + std::to_string(prior.size()) + " parameters, the model " + std::to_string(p));
  long rows = 0;
  for (int c = 0; c < nv; ++c) rows += train.rows(c);
  out.training_rows = rows;
  if (rows == 0) return fail("no training data");
  if (rows < m) {
    return fail("too little data: " + std::to_string(rows) + " equations for " + std::to_string(m) +
                " base parameters (" + std::to_string(train.samples()) + " samples)");
  }
  ScaledProblem sp = scaleProblem(train, model, prior, o.method);
  out.singular_values = sp.s;
  out.row_weight = sp.row_weight;
  out.numerical_rank = sp.numericalRank();
  if (out.numerical_rank == 0) return fail("the data excite no parameter (every singular value is zero)");
  LsqFactor vfactor;
  if (validation) vfactor = toStandard(validation->mergedBase(), validation->base().base_map);
  std::string why;
  if (!chooseRank(train, model, prior, o, validation, sp, vfactor, processing, out, why)) return fail(why);
  out.rank = std::min(out.rank, out.numerical_rank);
  sp = orderDirections(sp, out.curve.order);  // a rule that keeps a set of directions: those first
  out.phi = solveAtRank(sp, out.rank);
  if (o.held_function.j >= 0) {
    if (o.held_function.c.size() != p || o.held_function.j >= p || o.held_function.c[o.held_function.j] != 1.0)
      return fail("the held function does not match the model (c of size p, c_j = 1)");
    o.held_function.apply(out.phi);
  }
  if (o.physically_consistent) makePhysicallyConsistent(model, sp, o, out);
  out.phi_base = train.base().base_map * out.phi;
  out.condition = out.rank > 0 ? sp.s[0] / sp.s[out.rank - 1] : 1.0;
  classifyExcitation(sp, prior, o.excitation_threshold, out);
  for (int b = 0; b < model.nbodies; ++b)
    out.links.push_back(checkLink(model.body_names[b], out.phi.segment<kParamsPerBody>(model.bodyParamIndex(b))));
  reportFit(train, validation, vfactor, prior, o, rows, out);
  return true;
}

}  // namespace exoid::estimator
