#include "exoid/estimator/diagnose.hpp"

#include <boost/math/distributions/students_t.hpp>
#include <algorithm>
#include <cmath>

#include "exoid/estimator/diagnose_stages.hpp"

namespace exoid::estimator {

namespace {
constexpr const char* kNames[kEffectKinds] = {"viscous", "coulomb", "stribeck", "offset",      "armature",
                                              "gain",    "delay",   "elastic",  "elastic_exp", "elastic_coupled",
                                              "elastic_exp_coupled"};
constexpr const char* kWords[kEffectKinds] = {"viscous friction",     "Coulomb friction", "Stribeck friction (static excess)",
                                              "constant torque offset", "armature (rotor inertia)",
                                              "torque-sensor gain error", "time delay of the torque",
                                              "joint elasticity (linear spring)", "joint elasticity (exponential spring)",
                                              "biarticular elasticity",
                                              "biarticular elasticity (exponential of two angles)"};
constexpr const char* kUnits[kEffectKinds] = {"N m s/rad", "N m", "N m", "N m", "kg m^2", "", "s", "N m/rad", "N m/rad", "N m/rad",
                                              "N m/rad"};
}  // namespace

const char* effectKindName(EffectKind k) { return kNames[static_cast<int>(k)]; }
const char* effectKindWords(EffectKind k) { return kWords[static_cast<int>(k)]; }
const char* effectUnit(EffectKind k) { return kUnits[static_cast<int>(k)]; }
bool parseEffectKind(const std::string& name, EffectKind& k) {
  for (int i = 0; i < kEffectKinds; ++i)
    if (name == kNames[i]) return k = static_cast<EffectKind>(i), true;
  return false;
}
bool isMeasurementEffect(EffectKind k) { return k == EffectKind::GainError || k == EffectKind::Delay; }
bool isDryFriction(EffectKind k) { return k == EffectKind::Coulomb || k == EffectKind::Stribeck; }
bool isElastic(EffectKind k) {
  return k == EffectKind::Elastic || k == EffectKind::ElasticExp || k == EffectKind::ElasticCoupled ||
         k == EffectKind::ElasticExpCoupled;
}
bool isCoupled(EffectKind k) { return k == EffectKind::ElasticCoupled || k == EffectKind::ElasticExpCoupled; }
EffectKind refinedKind(EffectKind k) {
  switch (k) {
    case EffectKind::Stribeck: return EffectKind::Coulomb;
    case EffectKind::ElasticExp: return EffectKind::Elastic;
    case EffectKind::ElasticExpCoupled: return EffectKind::ElasticExp;
    default: return k;
  }
}
EffectKind effectFamily(EffectKind k) {
  if (isElastic(k)) return EffectKind::Elastic;
  return isDryFriction(k) ? EffectKind::Coulomb : k;
}
bool admissibleValue(EffectKind k, double value) {
  switch (k) {
    case EffectKind::Viscous:
    case EffectKind::Coulomb:
    case EffectKind::Stribeck:
    case EffectKind::Armature:
    case EffectKind::Elastic:
    case EffectKind::ElasticExp:
    case EffectKind::ElasticExpCoupled:
      return value >= 0.0;
    case EffectKind::Delay:
      return std::fabs(value) <= kMaxLinearisedDelay;
    default:
      return true;
  }
}

EffectShape effectShape(const EffectShape& shape, const Effect& effect) {
  EffectShape s = shape;
  if (effect.width > 0.0 && isDryFriction(effect.kind))
    s.coulomb_width = effect.width;
  if (isElastic(effect.kind)) s.center = effect.center;
  if (effect.kind == EffectKind::ElasticExp || effect.kind == EffectKind::ElasticExpCoupled) s.elastic_scale = effect.width;
  return s;
}

double effectSignal(EffectKind k, const EffectShape& shape, double q, double v, double a, double tau_model,
                    double dtau_model) {
  switch (k) {
    case EffectKind::Viscous: return v;
    case EffectKind::Coulomb: return std::tanh(v / shape.coulomb_width);
    case EffectKind::Stribeck: {
      const double r = v / shape.stribeck_velocity;
      return std::tanh(v / shape.coulomb_width) * std::exp(-r * r);
    }
    case EffectKind::Offset: return 1.0;
    case EffectKind::Armature: return a;
    case EffectKind::GainError: return tau_model;
    case EffectKind::Delay: return -dtau_model;
    case EffectKind::Elastic:
    case EffectKind::ElasticCoupled: return q - shape.center;  // q: the coupled joint's (signalJoint)
    case EffectKind::ElasticExp:
    case EffectKind::ElasticExpCoupled: {  // q: effectAngle's q_j + r (q_c - coupled_center)
      // Slope 1 at the center, the linear spring as |s| grows. The exponent is capped at 50 (e^50 ~ 5e21): a posture that
      // far past the scale is outside any tissue's range, and an overflow would poison every fit the column enters.
      const double sc = shape.elastic_scale, x = q - shape.center;
      return sc != 0.0 ? sc * std::expm1(std::min(x / sc, 50.0)) : x;
    }
  }
  return 0.0;
}

// ---------------------------------------------------------------------------------------------------------
// Student's t from Boost.Math; its errors set errno and give NaN instead of throwing (the diagnosis never throws).
namespace {
namespace bmp = boost::math::policies;
using NoThrow = bmp::policy<bmp::domain_error<bmp::errno_on_error>, bmp::pole_error<bmp::errno_on_error>,
                            bmp::overflow_error<bmp::errno_on_error>, bmp::evaluation_error<bmp::errno_on_error>>;
}  // namespace

double studentTUpperTail(double t, double dof) {
  if (std::isnan(t) || !(dof > 0.0)) return 1.0;
  if (std::isinf(t)) return t > 0 ? 0.0 : 1.0;
  const double p = boost::math::cdf(boost::math::complement(boost::math::students_t_distribution<double, NoThrow>(dof), t));
  return std::isfinite(p) ? p : 1.0;
}

double signedRankUpperTail(const Eigen::VectorXd& d) {
  if (!d.allFinite()) return 1.0;
  std::vector<double> x;  // the nonzero values (Wilcoxon: zeros carry no sign)
  for (int i = 0; i < d.size(); ++i)
    if (d[i] != 0.0) x.push_back(d[i]);
  const int n = static_cast<int>(x.size());
  if (n == 0) return 1.0;
  std::sort(x.begin(), x.end(), [](double a, double b) { return std::fabs(a) < std::fabs(b); });
  // Ranks in doubled units, so that a tie's mean rank (i + j + 2) / 2 stays an integer; the statistic 2 W+.
  std::vector<int> rank2(static_cast<size_t>(n));
  int w2 = 0;
  for (int i = 0; i < n;) {
    int j = i;
    while (j + 1 < n && std::fabs(x[static_cast<size_t>(j + 1)]) == std::fabs(x[static_cast<size_t>(i)])) ++j;
    for (int k = i; k <= j; ++k) rank2[static_cast<size_t>(k)] = i + j + 2;
    i = j + 1;
  }
  int reach = 0;
  for (int i = 0; i < n; ++i) {
    reach += rank2[static_cast<size_t>(i)];
    if (x[static_cast<size_t>(i)] > 0) w2 += rank2[static_cast<size_t>(i)];
  }
  // The number of sign patterns giving each value of 2 W+: each rank in or out.
  std::vector<double> count(static_cast<size_t>(reach + 1), 0.0);
  count[0] = 1.0;
  int at = 0;
  for (int i = 0; i < n; ++i) {
    const int r = rank2[static_cast<size_t>(i)];
    for (int s = at; s >= 0; --s) count[static_cast<size_t>(s + r)] += count[static_cast<size_t>(s)];
    at += r;
  }
  double upper = 0.0;
  for (int s = w2; s <= reach; ++s) upper += count[static_cast<size_t>(s)];
  return std::min(1.0, upper / std::ldexp(1.0, n));
}

// ---------------------------------------------------------------------------------------------------------
// The diagnosis: the stages of diagnose_stages.hpp, in order.
bool diagnose(const Model& model, const std::vector<Segment>& train, const std::vector<Segment>& validate,
              const DiagnoseOptions& opt, DiagnosisResult& out, std::string* error) {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (train.empty()) return fail("no training data");
  if (opt.folds < 3) return fail("at least 3 folds are needed for the held-out test");
  if (!(opt.shape.coulomb_width > 0) || !(opt.shape.stribeck_velocity > 0))
    return fail("the Coulomb width and the Stribeck velocity must be positive");
  out = DiagnosisResult{};
  DiagnoseData data;
  declaredColumns(model, opt, train, validate, data, out);
  if (!trainingPass(model, opt, data, out, error) || !declaredFit(data, out, error)) return false;
  profileCoulombWidths(data);
  profileElasticScales(opt, data);
  profileCoupledElasticShapes(opt, data);
  if (!declaredPrediction(model, data, out, error)) return false;
  rowWeights(model, data);
  candidateSignals(model, opt, data, out);
  // The gain and delay signals are linearised about a reference prediction (first the declared model's); when they
  // are chosen, Gauss-Newton: the reference becomes the augmented model's rigid part and the accepted set is refitted,
  // until the values settle (the selection itself is made once). The selection runs in the first pass and, after a
  // payload is accepted while gain or delay candidates are tested, goes on in the next one, whose signals are
  // linearised about the model with the payload.
  data.S.resize(data.m);
  for (int c = 0; c < data.m; ++c) data.S[c] = c;
  data.pdone.assign(static_cast<size_t>(data.npl), 0);
  for (int gn = 0;; ++gn) {
    if (!foldFactors(model, opt, data, error)) return false;
    const bool again = data.selecting && selectEffects(model, opt, data, out);
    if (!again) data.selecting = false;
    const Eigen::VectorXd xprev = data.xa;
    finalFit(opt, data, out);
    const Eigen::VectorXd& xa = data.xa;
    const int m = data.m;
    bool linearised = false;
    for (const Finding& f : out.findings) linearised = linearised || isMeasurementEffect(f.effect.kind);
    const bool settled = gn > 0 && xa.size() == xprev.size() &&
                         (xa - xprev).tail(xa.size() - m).cwiseAbs().maxCoeff() <=
                             1e-6 * (1.0 + xa.tail(xa.size() - m).cwiseAbs().maxCoeff());
    if (!again && (!linearised || settled || gn >= 8 + static_cast<int>(data.pcol.size()))) break;
    if (!relinearise(model, data, error)) return false;
  }
  if (!residualSeries(model, opt, data, out, error)) return false;
  out.has_validation = !validate.empty();
  summarizeCoordinates(model, opt, data, out);
  // The last stage: is what remains predictable from the state at all?
  if (!residualPredictability(model, out.series, opt.alpha, opt.min_explained, out.pooled_after, opt.predictability,
                              out.predictability, error))
    return false;
  // Does an unmeasured body move on the base? (the base rows, which no joint effect reaches)
  if (!unmeasuredBodyResponse(model, out.series, opt.alpha, opt.min_explained, opt.unmeasured_body, out.unmeasured_body,
                              error))
    return false;
  describeFindings(model, opt, out);
  return true;
}

}  // namespace exoid::estimator
