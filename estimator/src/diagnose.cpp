#include "exoid/estimator/diagnose.hpp"

#include <cmath>

#include "exoid/estimator/diagnose_stages.hpp"

namespace exoid::estimator {

namespace {
constexpr const char* kNames[kEffectKinds] = {"viscous", "coulomb", "stribeck", "offset", "armature", "gain", "delay"};
constexpr const char* kWords[kEffectKinds] = {"viscous friction",     "Coulomb friction", "Stribeck friction (static excess)",
                                              "constant torque offset", "armature (rotor inertia)",
                                              "torque-sensor gain error", "time delay of the torque"};
constexpr const char* kUnits[kEffectKinds] = {"N m s/rad", "N m", "N m", "N m", "kg m^2", "", "s"};
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
bool admissibleValue(EffectKind k, double value) {
  switch (k) {
    case EffectKind::Viscous:
    case EffectKind::Coulomb:
    case EffectKind::Stribeck:
    case EffectKind::Armature:
      return value >= 0.0;
    default:
      return true;
  }
}

EffectShape effectShape(const EffectShape& shape, const Effect& effect) {
  EffectShape s = shape;
  if (effect.width > 0.0 && isDryFriction(effect.kind))
    s.coulomb_width = effect.width;
  return s;
}

double effectSignal(EffectKind k, const EffectShape& shape, double v, double a, double tau_model, double dtau_model) {
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
  }
  return 0.0;
}

// ---------------------------------------------------------------------------------------------------------
// Student's t tail through the regularised incomplete beta function (continued fraction, Lentz).
namespace {
double betaContinuedFraction(double a, double b, double x) {
  const double tiny = 1e-300;
  double c = 1.0, d = 1.0 - (a + b) * x / (a + 1.0);
  if (std::fabs(d) < tiny) d = tiny;
  d = 1.0 / d;
  double h = d;
  for (int m = 1; m <= 300; ++m) {
    const double m2 = 2.0 * m;
    double aa = m * (b - m) * x / ((a + m2 - 1.0) * (a + m2));
    d = 1.0 + aa * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    h *= d * c;
    aa = -(a + m) * (a + b + m) * x / ((a + m2) * (a + m2 + 1.0));
    d = 1.0 + aa * d;
    if (std::fabs(d) < tiny) d = tiny;
    c = 1.0 + aa / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-15) break;
  }
  return h;
}
// I_x(a, b)
double incompleteBeta(double a, double b, double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  const double lbt = std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log1p(-x);
  if (x < (a + 1.0) / (a + b + 2.0)) return std::exp(lbt) * betaContinuedFraction(a, b, x) / a;
  return 1.0 - std::exp(lbt) * betaContinuedFraction(b, a, 1.0 - x) / b;
}
}  // namespace

double studentTUpperTail(double t, double dof) {
  if (std::isnan(t)) return 1.0;
  if (std::isinf(t)) return t > 0 ? 0.0 : 1.0;
  const double tail = 0.5 * incompleteBeta(0.5 * dof, 0.5, dof / (dof + t * t));  // P(T >= |t|)
  return t >= 0.0 ? tail : 1.0 - tail;
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
  describeFindings(model, opt, out);
  return true;
}

}  // namespace exoid::estimator
