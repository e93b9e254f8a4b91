// ComObserver: the moment balance's CoM against a rigid body's wrench built here, the complementary pair against its
// transfer function evaluated independently (complex polynomials from the Butterworth poles), both anchors (the
// plates, the model), a plate offset, the start, the restart and the hold.
#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <vector>

#include <Eigen/Geometry>

#include "exoid/controller/com_observer.hpp"

namespace exoid::controller {
namespace {

constexpr double kPeriod = 0.001, kG = 9.81, kMass = 110.0;

// |L(j W)| of the pair's low-pass L = (a2 s^2 + a1 s + a0) / D, D = prod (s - p_k) over the 4th-order Butterworth
// poles w exp(j (pi/2 + (2k + 1) pi / 8)).
double lowPassGain(double w, double W) {
  const std::complex<double> s(0.0, W);
  std::complex<double> c[5] = {1.0, 0.0, 0.0, 0.0, 0.0};  // c[i]: coefficient of s^(4-i)
  for (int k = 0; k < 4; ++k) {
    const std::complex<double> p = std::polar(w, M_PI / 2.0 + (2.0 * k + 1.0) * M_PI / 8.0);
    for (int i = k + 1; i >= 1; --i) c[i] -= p * c[i - 1];
  }
  const std::complex<double> D = (((c[0] * s + c[1]) * s + c[2]) * s + c[3]) * s + c[4];
  const std::complex<double> N = (c[2] * s + c[3]) * s + c[4];
  return std::abs(N / D);
}

ComObserverConfig config(ComObserverConfig::Anchor anchor = ComObserverConfig::Anchor::kModel) {
  ComObserverConfig c;
  c.enabled = true;
  c.anchor = anchor;
  c.crossover_hz = 0.2;
  c.anchor_time_constant = 20.0;
  c.settle_time = 3.0;
  return c;
}

// A system whose CoM is c(t) = (A sin(W t) + B sin(W2 t), -(same), 0.9), standing on plates that report its wrench
// exactly (m (c'' + g), moment about the origin c x F + dL/dt with the true dL/dt = (0, Lt sin(Wl t), 0)), plus a
// horizontal force offset. The observer gets the model's CoM c + bias + E sin(We t) (what the model holds rigid
// and is not) and an angular momentum with rate (0, Lm sin(Wl t), 0) (the model's own: Lm = Lt when it knows it).
struct Case {
  double A = 0.02, W = 2.0 * M_PI * 0.3, B = 0.004, W2 = 2.0 * M_PI * 3.0;
  double Lt = 0.0, Lm = 0.0, Wl = 2.0 * M_PI * 1.0;  // N m
  double E = 0.0, We = 2.0 * M_PI * 0.5, bias = 0.0;  // m
  double offset = 0.0;                                 // N
  double seconds = 60.0, from = 30.0;
};
struct Figures {
  double balance = 0.0;     // RMS of c_1 - c, x
  double plates = 0.0;      // RMS of c_P - c, x
  double controller = 0.0;  // RMS of (model + correction) - (c + bias), x
  double truth = 0.0;       // RMS of (model + correction) - c, x
  double velocity = 0.0;    // RMS of (model velocity + velocity correction) - c', x
};
Figures simulate(const Case& k, ComObserver& obs) {
  Figures f;
  int n = 0;
  const int ticks = static_cast<int>(k.seconds / kPeriod);
  for (int i = 0; i < ticks; ++i) {
    const double t = i * kPeriod;
    const double x = k.A * std::sin(k.W * t) + k.B * std::sin(k.W2 * t);
    const double xd = k.A * k.W * std::cos(k.W * t) + k.B * k.W2 * std::cos(k.W2 * t);
    const double xdd = -k.A * k.W * k.W * std::sin(k.W * t) - k.B * k.W2 * k.W2 * std::sin(k.W2 * t);
    const Eigen::Vector3d c(x, -x, 0.9), cdd(xdd, -xdd, 0.0);
    Eigen::Vector3d F = kMass * (cdd + Eigen::Vector3d(0.0, 0.0, kG));
    const Eigen::Vector3d ldot(0.0, k.Lt * std::sin(k.Wl * t), 0.0);
    const Eigen::Vector3d M = c.cross(F) + ldot;
    F.x() += k.offset;
    const double e = k.bias + k.E * std::sin(k.We * t), ed = k.E * k.We * std::cos(k.We * t);
    const Eigen::Vector3d model(x + e, -x - e, 0.9), model_v(xd + ed, -xd - ed, 0.0);
    const Eigen::Vector3d L(0.0, -k.Lm / k.Wl * std::cos(k.Wl * t), 0.0);  // its rate: (0, Lm sin(Wl t), 0)
    obs.update(model, model_v, L, &F, &M, kMass, 1);
    EXPECT_EQ(obs.correction().z(), 0.0);
    if (t >= k.from) {
      const auto sq = [](double v) { return v * v; };
      f.balance += sq(obs.balanceCom().x() - x);
      f.plates += sq(obs.platesCom().x() - x);
      f.controller += sq(model.x() + obs.correction().x() - (x + k.bias));
      f.truth += sq(model.x() + obs.correction().x() - x);
      f.velocity += sq(model_v.x() + obs.velocityCorrection().x() - xd);
      ++n;
    }
  }
  f.balance = std::sqrt(f.balance / n);
  f.plates = std::sqrt(f.plates / n);
  f.controller = std::sqrt(f.controller / n);
  f.truth = std::sqrt(f.truth / n);
  f.velocity = std::sqrt(f.velocity / n);
  return f;
}

TEST(ComObserver, TheMomentBalanceGivesTheCoMWhenTheAngularMomentumRateIsKnown) {
  // The system turns (dL/dt 20 N m at 1 Hz) and the model knows it: c_1 is the CoM to the rate filter's lag
  // (20 ms on a 1 Hz term: 20 N m x 0.126 / 1079 N = 2.3 mm peak, the bound below); not told, c_1 is off by
  // dL/dt / F_z (20 / 1079 N = 18.5 mm peak, 13.1 RMS).
  Case told;
  told.Lt = told.Lm = 20.0;
  ComObserver a(config(), kPeriod, kG);
  const Figures ft = simulate(told, a);
  EXPECT_LT(ft.balance, 0.0025 / std::sqrt(2.0));
  Case untold = told;
  untold.Lm = 0.0;
  ComObserver b(config(), kPeriod, kG);
  const Figures fu = simulate(untold, b);
  EXPECT_NEAR(fu.balance, 20.0 / (kMass * kG) / std::sqrt(2.0), 0.001);
  // ...and the pair takes that unknown 1 Hz term down by |L(j 2 pi)| at a 0.2 Hz crossover.
  EXPECT_NEAR(fu.plates, lowPassGain(2.0 * M_PI * 0.2, 2.0 * M_PI) * fu.balance, 0.05 * fu.plates + ft.plates);
  EXPECT_LT(fu.plates, 0.2 * fu.balance);  // 0.137: 3.41 (0.2 / 1)^2
}

TEST(ComObserver, TheControllersCoMKeepsTheModelsBiasAndLosesWhatTheModelMisses) {
  // The model is 3 mm off (its bias: the estimate's job) and misses a 0.5 Hz motion of 4 mm (the trunk): the
  // controller's CoM keeps the bias and follows the true motion, to the anchor's leak at 0.5 Hz (1 / |tau s + 1|,
  // 0.016) and the integration's error.
  Case k;
  k.bias = 0.003;
  k.E = 0.004;
  k.seconds = 120.0;
  k.from = 60.0;
  ComObserver obs(config(), kPeriod, kG);
  const Figures f = simulate(k, obs);
  const double missing = k.E / std::sqrt(2.0);
  EXPECT_LT(f.controller, 0.03 * missing);
  EXPECT_LT(f.velocity, 0.03 * k.E * k.We / std::sqrt(2.0) + 1e-3);
  EXPECT_DOUBLE_EQ(obs.weight(), 1.0);
  // Without the observer the controller's CoM would carry the whole missing motion: the test can fail.
  EXPECT_GT(missing, 30.0 * f.controller);
}

TEST(ComObserver, ThePlatesAnchorTakesTheModelsBiasAndItsSlowMisses) {
  const auto P = ComObserverConfig::Anchor::kPlates, Mo = ComObserverConfig::Anchor::kModel;
  // The model 3 mm off and missing a 0.5 Hz motion of 4 mm: with the plates' anchor the controller's CoM is the
  // true one (the bias gone too); with the model's it keeps the 3 mm (the case above).
  Case k;
  k.bias = 0.003;
  k.E = 0.004;
  k.seconds = 120.0;
  k.from = 60.0;
  ComObserver plates(config(P), kPeriod, kG), model(config(Mo), kPeriod, kG);
  const Figures fp = simulate(k, plates), fm = simulate(k, model);
  EXPECT_LT(fp.truth, 0.03 * k.E / std::sqrt(2.0));
  EXPECT_NEAR(fm.truth, k.bias, 0.03 * k.E);
  EXPECT_TRUE(plates.applies());
  // A miss slower than the model's anchor (a trunk's lean at 0.004 Hz, below its corner 1 / (2 pi 20 s) = 0.008
  // Hz): the model's anchor leaves 1 / |tau s + 1| = 0.89 of it, the plates' none (the pair's low-pass is 1 there).
  // Two whole periods of the lean from 300 s on.
  Case slow;
  slow.E = 0.004;
  slow.We = 2.0 * M_PI * 0.004;
  slow.seconds = 800.0;
  slow.from = 300.0;
  ComObserver plates_slow(config(P), kPeriod, kG), model_slow(config(Mo), kPeriod, kG);
  const Figures sp = simulate(slow, plates_slow), sm = simulate(slow, model_slow);
  const double lean = slow.E / std::sqrt(2.0), tw = 20.0 * slow.We;
  EXPECT_NEAR(sm.truth, lean / std::sqrt(1.0 + tw * tw), 0.05 * lean);
  EXPECT_LT(sp.truth, 0.02 * lean);  // the pair's own floor on the fast motion (0.04 mm; 0.9 mm without the plates)
}

TEST(ComObserver, APlateForceOffsetBiasesThePlatesCoMButNotTheControllers) {
  // 5 N horizontal offset on a 110 kg system. Twice integrated it would be a parabola; H / s^2 has a zero at s = 0,
  // so the acceleration path leaves none of it. The moment balance reads it as a lean of the ground force: c_1 moves
  // by c_z 5 N / F_z (4.2 mm), a constant that the anchor to the model removes from the controller's CoM.
  Case clean;
  clean.seconds = 200.0;
  clean.from = 180.0;
  Case offset = clean;
  offset.offset = 5.0;
  ComObserver a(config(), kPeriod, kG), b(config(), kPeriod, kG);
  const Figures fc = simulate(clean, a), fo = simulate(offset, b);
  EXPECT_NEAR(fo.plates, std::hypot(fc.plates, 0.9 * 5.0 / (kMass * kG)), 2e-5);
  EXPECT_LT(std::abs(fo.controller - fc.controller), 2e-5);
  EXPECT_LT(fc.controller, 1e-4);
  // The plates' anchor keeps it (what config/controller.yaml says it assumes: zeroed plates).
  ComObserver c(config(ComObserverConfig::Anchor::kPlates), kPeriod, kG),
      d(config(ComObserverConfig::Anchor::kPlates), kPeriod, kG);
  const Figures pc = simulate(clean, c), po = simulate(offset, d);
  EXPECT_LT(pc.truth, 1e-4);
  EXPECT_NEAR(po.truth, std::hypot(pc.truth, 0.9 * 5.0 / (kMass * kG)), 2e-5);
}

TEST(ComObserver, TheCorrectionEntersAfterTheSettleTimeAndStopsWithThePlates) {
  ComObserver obs(config(), kPeriod, kG);
  const Eigen::Vector3d c(0.01, -0.02, 0.9), v = Eigen::Vector3d::Zero(), L = Eigen::Vector3d::Zero();
  const Eigen::Vector3d F(0.0, 0.0, kMass * kG), M = c.cross(F);
  const Eigen::Vector3d model = c + Eigen::Vector3d(0.004, 0.0, 0.0);  // 4 mm off: the correction would be 4 mm
  std::vector<double> weights;
  for (int i = 0; i < 7000; ++i) {
    obs.update(model, v, L, &F, &M, kMass, 1);
    if (i % 1000 == 0) weights.push_back(obs.weight());
  }
  // t = 0, 1, ..., 6 s: 0 through the settle time (3 s), smoothstep to 1 at 6 s
  EXPECT_EQ(weights[0], 0.0);
  EXPECT_EQ(weights[3], 0.0);
  EXPECT_NEAR(weights[4], 7.0 / 27.0, 1e-3);  // r = 1/3: r^2 (3 - 2 r)
  EXPECT_NEAR(weights[5], 20.0 / 27.0, 1e-3);
  EXPECT_GT(weights[6], 0.999);
  EXPECT_TRUE(obs.fusing());
  // A model off by a constant from the start is the anchor's from the first tick: no correction.
  EXPECT_LT(obs.correction().norm(), 1e-9);
  // No plates, unloaded plates, disabled: the model alone, the observer restarts.
  obs.update(model, v, L, nullptr, &M, kMass, 1);
  EXPECT_FALSE(obs.fusing());
  EXPECT_EQ(obs.correction().norm(), 0.0);
  const Eigen::Vector3d light(0.0, 0.0, 0.4 * kMass * kG);
  obs.update(model, v, L, &light, &M, kMass, 1);
  EXPECT_FALSE(obs.fusing());
  obs.update(model, v, L, &F, &M, kMass, 1);  // restart: no correction until the settle time again
  obs.update(model, v, L, &F, &M, kMass, 1);
  EXPECT_TRUE(obs.fusing());
  EXPECT_EQ(obs.weight(), 0.0);
  EXPECT_EQ(obs.correction().norm(), 0.0);
  ComObserverConfig off = config();
  off.enabled = false;
  ComObserver none(off, kPeriod, kG);
  for (int i = 0; i < 10; ++i) none.update(model, v, L, &F, &M, kMass, 1);
  EXPECT_FALSE(none.fusing());
  EXPECT_FALSE(none.applies());
}

TEST(ComObserver, ThePlatesAnchorHoldsItsCorrectionWhileThePlatesAreLost) {
  ComObserver obs(config(ComObserverConfig::Anchor::kPlates), kPeriod, kG);
  const Eigen::Vector3d c(0.01, -0.02, 0.9), v = Eigen::Vector3d::Zero(), L = Eigen::Vector3d::Zero();
  const Eigen::Vector3d F(0.0, 0.0, kMass * kG), M = c.cross(F);
  const Eigen::Vector3d model = c + Eigen::Vector3d(0.004, 0.0, 0.0);  // 4 mm off
  for (int i = 0; i < 7000; ++i) obs.update(model, v, L, &F, &M, kMass, 1);
  EXPECT_GT(obs.weight(), 0.999);
  EXPECT_NEAR(obs.correction().x(), -0.004, 1e-6);  // the model's bias, measured
  EXPECT_NEAR(obs.correction().y(), 0.0, 1e-6);
  // The plates lost: the correction stays, its velocity 0, until they are back.
  for (int i = 0; i < 500; ++i) obs.update(model, v, L, nullptr, nullptr, kMass, 1);
  EXPECT_FALSE(obs.fusing());
  EXPECT_TRUE(obs.applies());
  EXPECT_NEAR(obs.correction().x(), -0.004, 1e-6);
  EXPECT_EQ(obs.velocityCorrection().norm(), 0.0);
  // Back, with the model now 1 mm off: the restarted pair blends from the held -4 mm to the new -1 mm over the
  // settle time (smoothstep from 3 to 6 s).
  const Eigen::Vector3d better = c + Eigen::Vector3d(0.001, 0.0, 0.0);
  std::vector<double> x;
  for (int i = 0; i <= 7000; ++i) {
    obs.update(better, v, L, &F, &M, kMass, 1);
    if (i % 1000 == 0) x.push_back(obs.correction().x());
  }
  EXPECT_NEAR(x[0], -0.004, 1e-6);
  EXPECT_NEAR(x[3], -0.004, 1e-6);
  EXPECT_NEAR(x[4], -0.004 + 7.0 / 27.0 * 0.003, 2e-6);
  EXPECT_NEAR(x[7], -0.001, 1e-6);
  // The controller's world fixed anew: nothing held.
  obs.reset();
  obs.update(better, v, L, nullptr, nullptr, kMass, 1);
  EXPECT_FALSE(obs.applies());
  EXPECT_EQ(obs.correction().norm(), 0.0);
}

// A rigid exoskeleton standing still (80 kg, CoM at 0.9 m) carrying an upper body (37 kg, inertia about its CoM
// diag(2.1, 1.55, 0.5) kg m^2, CoM 0.25 m above a pivot at 1.05 m) that turns about the pivot's y axis (axis 1,
// theta = A sin(W t)) or x axis (axis 0). The plates report the exact wrench: F = m c_t'' + M g z,
// M_O = dH_O/dt + M g c x z with H_O = I w + m c_t x c_t' (the exoskeleton does not move). The model holds the upper
// body rigid at theta = 0: its CoM, velocity and angular momentum are constant. The whole scene is turned by `yaw`
// about the world's z (the pelvis's heading), which the observer is told when `told`. Returns the RMS of c_1 - c along
// the pelvis's other horizontal axis (x for a pitch, y for a roll) over the last half of 20 s.
double upperBodyBalanceError(int axis, const Eigen::Vector2d& lever, double hz, double yaw = 0.0, bool told = true) {
  const double Mr = 80.0, m = 37.0, h = 0.25, A = 0.02, W = 2.0 * M_PI * hz;
  const Eigen::Vector3d cr(0.01, 0.0, 0.9), pivot(0.0, 0.0, 1.05), inertia(2.1, 1.55, 0.5);
  const double M = Mr + m;
  const Eigen::Vector3d c_rest = (Mr * cr + m * (pivot + Eigen::Vector3d(0.0, 0.0, h))) / M;
  ComObserver obs(config(), kPeriod, kG, lever);
  if (told) obs.setHeading(yaw);
  const Eigen::Matrix3d Rz = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const int along = axis == 1 ? 0 : 1;  // a pitch moves the CoM along x, a roll along -y
  const double sign = axis == 1 ? 1.0 : -1.0;
  double sum = 0.0;
  int n = 0;
  for (int i = 0; i < 20000; ++i) {
    const double t = i * kPeriod;
    const double th = A * std::sin(W * t), thd = A * W * std::cos(W * t), thdd = -A * W * W * std::sin(W * t);
    Eigen::Vector3d ct = pivot, ctdd = Eigen::Vector3d::Zero();
    ct[along] += sign * h * std::sin(th);
    ct.z() += h * std::cos(th);
    ctdd[along] = sign * h * (thdd * std::cos(th) - thd * thd * std::sin(th));
    ctdd.z() = -h * (thdd * std::sin(th) + thd * thd * std::cos(th));
    const Eigen::Vector3d c = (Mr * cr + m * ct) / M;
    const Eigen::Vector3d F = m * ctdd + Eigen::Vector3d(0.0, 0.0, M * kG);
    Eigen::Vector3d dH = m * ct.cross(ctdd);
    dH[axis] += inertia[axis] * thdd;  // about a principal axis: no gyroscopic term
    const Eigen::Vector3d Mo = dH + M * kG * c.cross(Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d F_world = Rz * F, Mo_world = Rz * Mo;  // moments about the origin turn as vectors
    obs.update(Rz * c_rest, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), &F_world, &Mo_world, M, 1);
    Eigen::Vector3d balance = obs.balanceCom();
    balance.z() = (Rz * c).z();
    if (t >= 10.0) sum += std::pow((Rz.transpose() * (balance - Rz * c))[along], 2), ++n;
  }
  return std::sqrt(sum / n);
}

TEST(ComObserver, TheUpperBodysTurningIsTakenFromTheForceTheModelLacks) {
  // The lever of upperBodyLever's formula for this body: I / (m h) + d, d its CoM above the system's at rest.
  const double m = 37.0, h = 0.25, d = 1.30 - (80.0 * 0.9 + 37.0 * 1.30) / 117.0;
  const Eigen::Vector2d lever(1.55 / (m * h) + d, 2.1 / (m * h) + d);
  for (int axis : {1, 0}) {
    const double without = upperBodyBalanceError(axis, Eigen::Vector2d::Zero(), 0.5);
    const double with = upperBodyBalanceError(axis, lever, 0.5);
    // Without it c_1 is off by dL/dt / F_z: (I + m d h) theta'' / (M g), 1.7-1.9 mm RMS here.
    const double I = axis == 1 ? 1.55 : 2.1, W = 2.0 * M_PI * 0.5;
    EXPECT_NEAR(without, (I + m * d * h) * 0.02 * W * W / std::sqrt(2.0) / (117.0 * kG), 0.03 * without) << axis;
    // With it, what is left is the 20 ms low-pass's lag on a 0.5 Hz term (2 pi 0.5 0.02 = 0.063 of it).
    EXPECT_LT(with, 0.08 * without) << axis;
  }
  // A wrong lever (the inertia alone, no orbital term) leaves more than twice as much.
  const Eigen::Vector2d short_lever(1.55 / (m * h), 2.1 / (m * h));
  EXPECT_GT(upperBodyBalanceError(1, short_lever, 0.5), 2.0 * upperBodyBalanceError(1, lever, 0.5));
  // A pelvis heading 90 degrees off the world's x: told, the same as at 0 (1e-9); not told, the pitch gets the
  // roll's lever, (kappa_y - kappa_x) / kappa_x = 13 % of the correction more.
  const double at0 = upperBodyBalanceError(1, lever, 0.5);
  EXPECT_NEAR(upperBodyBalanceError(1, lever, 0.5, M_PI / 2.0, true), at0, 1e-9);
  const double untold = upperBodyBalanceError(1, lever, 0.5, M_PI / 2.0, false);
  const double without = upperBodyBalanceError(1, Eigen::Vector2d::Zero(), 0.5);
  EXPECT_GT(untold, at0 + 0.5 * (lever.y() - lever.x()) / lever.x() * without);
}

}  // namespace
}  // namespace exoid::controller
