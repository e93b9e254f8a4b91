// The unmeasured-body stage (unmeasured_body.hpp) on synthetic base-row residuals of the exoskeleton's floating base:
// a pendulum body on a spring at the base, simulated with its exact nonlinear planar kinematics (not the stage's
// linearised filter), is named in its plane with its resonance; noise (white, or smooth and independent of the base's
// motion), a rigid body's wrench (quasi-static and a lead, what a change of the rigid parameters or a filter mismatch
// gives) and a stiff body far above the grid are not, over several seeds. Also the filter against G(j w).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <complex>
#include <random>
#include <string>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/estimator/unmeasured_body.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::estimator {
namespace {

TEST(UnmeasuredBody, TheSecondOrderResponseMatchesItsTransferFunctionInSteadyState) {
  for (const double f : {0.5, 1.4, 4.0})
    for (const double zeta : {0.15, 0.6})
      for (const double dt : {0.001, 0.01}) {
        const double W = 2 * M_PI * 0.9;  // input frequency, rad/s
        const long n = static_cast<long>(60.0 / dt);
        Eigen::VectorXd t(n), u(n), x, dx;
        for (long i = 0; i < n; ++i) t[i] = i * dt, u[i] = std::sin(W * t[i]);
        secondOrderResponse(t, u, f, zeta, x, dx);
        const double w = 2 * M_PI * f;
        const std::complex<double> G = w * w / (std::complex<double>(w * w - W * W, 2 * zeta * w * W));
        double emax = 0.0, dmax = 0.0;
        for (long i = 2 * n / 3; i < n; ++i) {  // the transient has decayed by 40 s (1 / (zeta w) <= 2.1 s)
          const std::complex<double> e = G * std::exp(std::complex<double>(0, W * t[i]));
          emax = std::max(emax, std::fabs(x[i] - e.imag()));
          dmax = std::max(dmax, std::fabs(dx[i] - (std::complex<double>(0, W) * e).imag()));
        }
        // u is linear between samples: at 10 ms the sine's chord error is ~(W dt)^2 / 8 = 4e-4 of its amplitude
        EXPECT_LT(emax, dt < 0.005 ? 1e-5 : 1e-3) << f << " Hz, zeta " << zeta << ", dt " << dt;
        EXPECT_LT(dmax, dt < 0.005 ? 1e-4 : 1e-2) << f << " Hz, zeta " << zeta << ", dt " << dt;
      }
}

// The base's motion: per input a sum of ten sines at frequencies log-uniform in 0.15-5 Hz (the moves of a balancing robot
// and the controller's corrections), specific force s_x, s_y ~ 0.3 m/s^2 RMS, angular accelerations ~ 0.5 rad/s^2 RMS,
// s_z = g.
constexpr int kSines = 10;
struct BaseMotion {
  double A[4][kSines], W[4][kSines], P[4][kSines];
  explicit BaseMotion(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> lf(std::log(0.15), std::log(5.0)), ph(0, 2 * M_PI), am(0.5, 1.0);
    const double scale[4] = {0.12, 0.12, 0.2, 0.2};  // s_x, s_y, alpha_x, alpha_y per sine
    for (int k = 0; k < 4; ++k)
      for (int h = 0; h < kSines; ++h) A[k][h] = scale[k] * am(rng), W[k][h] = 2 * M_PI * std::exp(lf(rng)), P[k][h] = ph(rng);
  }
  double operator()(int k, double t) const {
    double s = 0.0;
    for (int h = 0; h < kSines; ++h) s += A[k][h] * std::sin(W[k][h] * t + P[k][h]);
    return s;
  }
};

// A planar pendulum body (mass m, CoM h above a pivot at height hp on the base's z axis, inertia Jc about its CoM,
// spring k, damper c, its own torque: a wearer's sway) in the plane of input (s, alpha): its angle phi from the rigid
// pose by semi-implicit Euler at 0.1 ms with the exact nonlinear moment about the pivot, and the base-row wrench
// (moment about the base origin, horizontal force) it needs beyond the same body held rigid. Rows: [moment, force]
// per sample time; first_moment: m h sin(phi).
struct Body {
  double m = 37.0, h = 0.28, hp = 0.2, Jc = 1.3, k = 0.0, c = 0.0;
};
void bodyWrench(const Body& b, const std::function<double(double)>& s, const std::function<double(double)>& alpha,
                const std::function<double(double)>& torque, const Eigen::VectorXd& t, Eigen::MatrixXd& dw,
                Eigen::VectorXd* first_moment = nullptr) {
  const double g = 9.81, Jp = b.Jc + b.m * b.h * b.h, step = 1e-4;
  dw.resize(t.size(), 2);
  double phi = 0.0, om = 0.0, tt = 0.0;
  auto accel = [&](double time, double p, double w) {
    // J_p (phi'' + alpha) = -k phi - c phi' + m h (sin(phi) s_z - cos(phi) s_x) + the body's own torque
    return (-b.k * p - b.c * w + b.m * b.h * (std::sin(p) * g - std::cos(p) * s(time)) + torque(time)) / Jp - alpha(time);
  };
  auto wrench = [&](double time, double p, double w, double a) {
    // CoM specific force in the base frame (x, z): the pivot's (s_x, g), alpha x r, the relative acceleration r''
    const double rx = b.h * std::sin(p), rz = b.h * std::cos(p), al = alpha(time);
    const double ax = s(time) + al * rz + b.h * (std::cos(p) * a - std::sin(p) * w * w);
    const double az = g - al * rx + b.h * (-std::sin(p) * a - std::cos(p) * w * w);
    const double fx = b.m * ax, fz = b.m * az;
    const double ny = (b.hp + rz) * fx - rx * fz + b.Jc * (al + a);  // about the base origin, y
    return Eigen::Vector2d(ny, fx);
  };
  for (long i = 0; i < t.size(); ++i) {
    while (tt < t[i] - 1e-12) {
      const double a = accel(tt, phi, om);
      om += step * a, phi += step * om, tt += step;
    }
    dw.row(i) = (wrench(t[i], phi, om, accel(t[i], phi, om)) - wrench(t[i], 0.0, 0.0, -alpha(t[i]))).transpose();
    if (first_moment) (*first_moment)[i] = b.m * b.h * std::sin(phi);
  }
}

// One run at 500 Hz: the base's motion in ResidualSeries::base, white noise (sigma_white N m / N) plus an
// Ornstein-Uhlenbeck noise of 1 s correlation time (sigma_smooth) on the four tested rows, plus the sagittal `effect`.
using BaseRowEffect = std::function<void(const BaseMotion&, const Eigen::VectorXd& t, Eigen::MatrixXd& dw)>;
ResidualSeries makeRun(const Model& model, uint64_t seed, double duration, double sigma_white, double sigma_smooth,
                       const BaseRowEffect& effect, bool validation, bool frontal = false) {
  std::mt19937_64 rng(seed);
  const BaseMotion motion(rng);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const double dt = 0.002;
  const long n = static_cast<long>(duration / dt);
  ResidualSeries rs;
  rs.segment = "run" + std::to_string(seed);
  rs.validation = validation;
  rs.t.resize(n);
  rs.after.setZero(n, model.nv), rs.base.setZero(n, 6);
  for (long i = 0; i < n; ++i) {
    rs.t[i] = i * dt;
    rs.base(i, 0) = motion(2, rs.t[i]), rs.base(i, 1) = motion(3, rs.t[i]);
    rs.base(i, 3) = motion(0, rs.t[i]), rs.base(i, 4) = motion(1, rs.t[i]), rs.base(i, 5) = 9.81;
  }
  const double a = std::exp(-dt / 1.0);
  double ou[4] = {gauss(rng), gauss(rng), gauss(rng), gauss(rng)};
  const int rows[4] = {0, 1, 3, 4};
  for (long i = 0; i < n; ++i)
    for (int r = 0; r < 4; ++r) {
      ou[r] = a * ou[r] + std::sqrt(1 - a * a) * gauss(rng);
      rs.after(i, rows[r]) = sigma_white * gauss(rng) + sigma_smooth * ou[r];
    }
  if (effect) {
    Eigen::MatrixXd dw;
    effect(motion, rs.t, dw);
    // the plane's rows: sagittal n_y, f_x; frontal: the same body leaning about -x, so n_x = -n, f_y = f
    if (frontal) rs.after.col(0) -= dw.col(0), rs.after.col(4) += dw.col(1);
    else rs.after.col(1) += dw.col(0), rs.after.col(3) += dw.col(1);
  }
  return rs;
}

Model exoModel() {
  Model model;
  std::string err;
  EXPECT_TRUE(buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, model, &err)) << err;
  return model;
}

UnmeasuredBodyResult run(const Model& model, uint64_t seed, double sigma_white, double sigma_smooth, const BaseRowEffect& effect,
                         bool frontal = false) {
  std::vector<ResidualSeries> series = {makeRun(model, seed, 60.0, sigma_white, sigma_smooth, effect, false, frontal),
                                        makeRun(model, seed + 1000, 40.0, sigma_white, sigma_smooth, effect, true, frontal)};
  UnmeasuredBodyResult res;
  std::string err;
  EXPECT_TRUE(unmeasuredBodyResponse(model, series, 0.01, 0.02, UnmeasuredBodyOptions{}, res, &err)) << err;
  return res;
}

// The pendulum at natural frequency f_hz and damping ratio zeta, driven by the base (s_x, alpha_y; x base_gain) and,
// with sway > 0, by its own torque like the simulator's (sim/src/wearer.cpp: white noise through a first-order low-pass
// at 0.5 Hz): 24 sines at log-spaced frequencies 0.05-3 Hz, each carrying its band's share of that spectrum, sway N m RMS.
BaseRowEffect pendulum(double f_hz, double zeta, double sway = 0.0, double base_gain = 1.0, bool frontal = false) {
  return [f_hz, zeta, sway, base_gain, frontal](const BaseMotion& motion, const Eigen::VectorXd& t, Eigen::MatrixXd& dw) {
    Body b;
    const double Jp = b.Jc + b.m * b.h * b.h, w = 2 * M_PI * f_hz;
    b.k = Jp * w * w + b.m * 9.81 * b.h, b.c = 2 * zeta * w * Jp;  // k - m g h = J w^2
    std::mt19937_64 rng(static_cast<uint64_t>(1000 * f_hz + 10 * zeta + sway));
    std::uniform_real_distribution<double> ph(0, 2 * M_PI);
    constexpr int kS = 24;
    double W[kS], P[kS], A[kS], power = 0.0;
    for (int h = 0; h < kS; ++h) {
      const double fr = 0.05 * std::pow(60.0, (h + 0.5) / kS);  // 0.05-3 Hz
      W[h] = 2 * M_PI * fr, P[h] = ph(rng), A[h] = std::sqrt(fr / (1 + fr * fr / 0.25)), power += A[h] * A[h] / 2;
    }
    const auto torque = [&](double x) {
      double q = 0.0;
      for (int h = 0; h < kS; ++h) q += A[h] * std::sin(W[h] * x + P[h]);
      return sway * q / std::sqrt(power);
    };
    // frontal: the body leans about -x, driven by s_y and -alpha_x
    bodyWrench(b, [&](double x) { return base_gain * motion(frontal ? 1 : 0, x); },
               [&](double x) { return frontal ? -base_gain * motion(2, x) : base_gain * motion(3, x); }, torque, t, dw);
  };
}

TEST(UnmeasuredBody, APendulumBodyOnASpringIsNamedInItsPlaneWithItsResonance) {
  const Model model = exoModel();
  // A trunk of 37 kg at 0.28 m (the 75 kg wearer's upper body), at three resonances across the grid, two damping
  // ratios; noise 0.3 N m / N white + 0.3 smooth (the base rows' residual of a simulated run without a body).
  int k = 0;
  for (const double f : {0.8, 1.25, 2.5})
    for (const double zeta : {0.2, 0.5}) {
      const UnmeasuredBodyResult res = run(model, 40 + k++, 0.3, 0.3, pendulum(f, zeta));
      ASSERT_TRUE(res.ran);
      ASSERT_EQ(res.planes.size(), 2u);
      const UnmeasuredBodyPlane& sag = res.planes[0];
      EXPECT_EQ(sag.plane, "sagittal");
      EXPECT_TRUE(sag.found) << f << " Hz, zeta " << zeta << ": gain " << sag.driven.gain << ", p " << sag.driven.p;
      EXPECT_TRUE(sag.driven.passed);
      std::printf("body %.2f Hz, zeta %.1f: driven %d at %.2f Hz, zeta %.2f, share %.3f (null %.3f), gain %.3f +- %.3f "
                  "(validation %.3f), p %.2g; gravity %d b/g %.2f gain %.3f p %.2g; frontal %s\n", f, zeta,
                  sag.driven.passed, sag.frequency_hz, sag.damping_ratio, sag.driven.share, sag.driven.null_share,
                  sag.driven.gain, sag.driven.se, sag.driven.validation_gain, sag.driven.p, sag.gravity.passed,
                  sag.gravity_ratio, sag.gravity.gain, sag.gravity.p, res.planes[1].verdict.c_str());
      // the chosen resonance within one grid step (a factor 2^(1/4)) of the body's
      EXPECT_LT(std::fabs(std::log(sag.frequency_hz / f)), 0.25 * std::log(2.0) * 1.01) << f << " Hz: " << sag.frequency_hz;
      // beyond the null on held-out data (a well-damped body above the input band differs least from a rigid one)
      EXPECT_GT(sag.driven.gain, zeta < 0.3 ? 0.3 : 0.05) << f << " Hz, zeta " << zeta;
      EXPECT_GT(sag.driven.validation_gain, zeta < 0.3 ? 0.3 : 0.05) << f << " Hz, zeta " << zeta;
      EXPECT_GT(sag.driven.share, sag.driven.null_share + sag.driven.gain - 1e-9);
      EXPECT_FALSE(res.planes[1].found) << "frontal: " << res.planes[1].verdict;
      EXPECT_FALSE(sag.sentence.empty());
      EXPECT_NE(sag.sentence.find("unmeasured body"), std::string::npos);
    }
}

TEST(UnmeasuredBody, ABodyMovedByItsOwnTorqueShowsTheGravitySignature) {
  const Model model = exoModel();
  // The same trunk swaying under its own torque (5 N m RMS, below 0.5 Hz) with the base nearly still (its motion x 0.1):
  // the driven response has little to go on, the gravity signature holds whatever moves the body: b / g near 1. Noise
  // 0.1 white + 0.1 smooth, the empty exoskeleton's base-row residual (0.13-0.16 N m / N RMS on the clean runs): the
  // first moment is the force row's double integral, so its low-frequency noise decides what a small sway shows.
  int k = 0;
  for (const double f : {0.8, 1.25, 2.5}) {
    const UnmeasuredBodyResult res = run(model, 70 + k++, 0.1, 0.1, pendulum(f, 0.3, 5.0, 0.1));
    ASSERT_TRUE(res.ran);
    const UnmeasuredBodyPlane& sag = res.planes[0];
    std::printf("sway, body %.2f Hz: gravity %d b/g %.2f lever %.2f first moment %.3g share %.3f (null %.3f) gain %.3f "
                "+- %.3f p %.2g; driven %d; frontal %s\n", f, sag.gravity.passed, sag.gravity_ratio, sag.lever,
                sag.first_moment_rms, sag.gravity.share, sag.gravity.null_share, sag.gravity.gain, sag.gravity.se,
                sag.gravity.p, sag.driven.passed, res.planes[1].verdict.c_str());
    EXPECT_TRUE(sag.found) << f << " Hz";
    EXPECT_TRUE(sag.gravity.passed) << f << " Hz";
    // b / g: 1 for a moving mass, lower where the body moves little against the moment row's noise (the stiffest)
    EXPECT_GT(sag.gravity_ratio, f < 2 ? 0.8 : 0.4) << f << " Hz";
    EXPECT_LT(sag.gravity_ratio, 1.2) << f << " Hz";
    // the moving mass's height above the base origin: pivot 0.2 + CoM 0.28 + Jc / (m h) 0.125 = 0.605 m
    EXPECT_NEAR(sag.lever, 0.605, f < 2 ? 0.05 : 0.1) << f << " Hz";
    EXPECT_FALSE(res.planes[1].found) << "frontal: " << res.planes[1].verdict;
    EXPECT_NE(sag.sentence.find("double integral"), std::string::npos) << sag.sentence;
  }
}

TEST(UnmeasuredBody, AFrontalBodyIsNamedInTheFrontalPlaneWithGravitysSign) {
  const Model model = exoModel();
  // The same trunk leaning sideways (about -x): rows base_nx = -n, base_fy = f, inputs s_y and -alpha_x. Checks the
  // frontal plane's rows, inputs and the sign of g in its signature (n_x = -z f_y + g p_y).
  const UnmeasuredBodyResult driven = run(model, 90, 0.3, 0.3, pendulum(2.0, 0.3, 0.0, 1.0, true), true);
  const UnmeasuredBodyResult sway = run(model, 91, 0.1, 0.1, pendulum(1.25, 0.3, 5.0, 0.1, true), true);
  ASSERT_TRUE(driven.ran && sway.ran);
  for (const UnmeasuredBodyResult* res : {&driven, &sway}) {
    EXPECT_EQ(res->planes[1].plane, "frontal");
    EXPECT_TRUE(res->planes[1].found) << res->planes[1].verdict;
    EXPECT_FALSE(res->planes[0].found) << "sagittal: " << res->planes[0].verdict;
  }
  const UnmeasuredBodyPlane& d = driven.planes[1];
  EXPECT_TRUE(d.driven.passed);
  EXPECT_LT(std::fabs(std::log(d.frequency_hz / 2.0)), 0.25 * std::log(2.0) * 1.01) << d.frequency_hz;
  const UnmeasuredBodyPlane& g = sway.planes[1];
  EXPECT_TRUE(g.gravity.passed) << g.gravity.p;
  EXPECT_GT(g.gravity_ratio, 0.8);
  EXPECT_LT(g.gravity_ratio, 1.2);
  EXPECT_NEAR(g.lever, 0.605, 0.05);
  std::printf("frontal: driven %.2f Hz gain %.3f p %.2g; sway b/g %.2f height %.3f gain %.3f p %.2g\n", d.frequency_hz,
              d.driven.gain, d.driven.p, g.gravity_ratio, g.lever, g.gravity.gain, g.gravity.p);
}

TEST(UnmeasuredBody, NoiseARigidBodyAndAStiffBodyAreNotNamed) {
  const Model model = exoModel();
  const BaseRowEffect rigid = [](const BaseMotion& motion, const Eigen::VectorXd& t, Eigen::MatrixXd& dw) {
    // what a rigid-parameter change and a 20 ms lead between the plates and the kinematics give: u and u(t + 20 ms)
    dw.resize(t.size(), 2);
    for (long i = 0; i < t.size(); ++i) {
      const double s = motion(0, t[i] + 0.02), a = motion(3, t[i] + 0.02);
      dw(i, 0) = 4.0 * s + 2.0 * a, dw(i, 1) = 30.0 * s + 3.0 * a;
    }
  };
  for (uint64_t seed : {1, 2, 3}) {
    for (const auto& [name, effect, white, smooth] :
         std::vector<std::tuple<std::string, BaseRowEffect, double, double>>{{"white noise", nullptr, 0.5, 0.0},
                                                                      {"smooth noise", nullptr, 0.1, 0.5},
                                                                      {"rigid body and a lead", rigid, 0.3, 0.3},
                                                                      {"stiff body (20 Hz)", pendulum(20.0, 0.3), 0.3, 0.3}}) {
      const UnmeasuredBodyResult res = run(model, 100 * seed, white, smooth, effect);
      ASSERT_TRUE(res.ran);
      for (const UnmeasuredBodyPlane& p : res.planes)
        EXPECT_FALSE(p.found) << name << ", seed " << seed << ", " << p.plane << ": " << p.verdict << "; driven gain "
                              << p.driven.gain << ", p " << p.driven.p << ", " << p.frequency_hz << " Hz; gravity b/g "
                              << p.gravity_ratio << ", gain " << p.gravity.gain << ", p " << p.gravity.p;
    }
  }
}

TEST(UnmeasuredBody, AFixedBaseOrAHeldBaseHasNothingToTest) {
  const Model model = exoModel();
  std::vector<ResidualSeries> series = {makeRun(model, 7, 30.0, 0.3, 0.0, pendulum(1.25, 0.3), false)};
  series[0].held_base = true;
  UnmeasuredBodyResult res;
  std::string err;
  ASSERT_TRUE(unmeasuredBodyResponse(model, series, 0.01, 0.02, UnmeasuredBodyOptions{}, res, &err)) << err;
  EXPECT_FALSE(res.ran);
  UnmeasuredBodyOptions bad;
  bad.frequencies_hz = {12.0};  // above the null's filter
  series[0].held_base = false;
  EXPECT_FALSE(unmeasuredBodyResponse(model, series, 0.01, 0.02, bad, res, &err));
  EXPECT_NE(err.find("null"), std::string::npos) << err;
}

}  // namespace
}  // namespace exoid::estimator
