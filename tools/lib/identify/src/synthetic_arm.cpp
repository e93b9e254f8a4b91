#include "exoid/tools/synthetic_arm.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <random>
#include <sstream>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"

namespace exoid::tools {

namespace {
// Platform-independent draws from mt19937_64's raw output (no standard distribution).
struct Draw {
  std::mt19937_64 rng;
  explicit Draw(uint64_t seed) : rng(seed) {}
  double unit() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
  double uniform(double a, double b) { return a + (b - a) * unit(); }
  double normal() {  // Box-Muller
    const double u1 = 1.0 - unit(), u2 = unit();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }
  int integer(int n) { return static_cast<int>(unit() * n) % n; }
};

Eigen::Matrix3d randomRotation(Draw& d) {
  const Eigen::Quaterniond q(d.normal(), d.normal(), d.normal(), d.normal());
  return q.normalized().toRotationMatrix();
}

std::string vec(const Eigen::Vector3d& v) {
  char b[128];
  std::snprintf(b, sizeof b, "%.17g %.17g %.17g", v[0], v[1], v[2]);
  return b;
}

// Trajectory of one joint: q0 + sum_k A_k sin(k w t + phase_k).
struct JointMotion {
  double q0 = 0.0;
  std::vector<double> amplitude, phase;
};

std::vector<JointMotion> drawMotion(int joints, const ArmRunOptions& o, Draw& d) {
  const double w = 2.0 * M_PI * 0.1;
  std::vector<JointMotion> m(joints);
  for (JointMotion& j : m) {
    j.q0 = d.uniform(-0.5, 0.5);
    double sum_a = 0.0, sum_v = 0.0;
    for (int k = 1; k <= o.harmonics; ++k) {
      j.amplitude.push_back(d.uniform(0.3, 1.0) / k);
      j.phase.push_back(d.uniform(0.0, 2.0 * M_PI));
      sum_a += j.amplitude.back();
      sum_v += j.amplitude.back() * k * w;
    }
    // |q - q0| <= 1 rad and |v| <= max_velocity (bounds by the sums of amplitudes).
    const double scale = std::min(1.0 / sum_a, o.max_velocity / sum_v);
    for (double& a : j.amplitude) a *= scale;
  }
  return m;
}

// Noise-free run of the arm with parameters phi (+ offsets).
ArmRun exactRun(const Model& model, const Eigen::VectorXd& phi, const Eigen::VectorXd& offset,
                const std::vector<JointMotion>& motion, const ArmRunOptions& o) {
  const int n = static_cast<int>(std::floor(o.duration * o.rate)) + 1, nj = model.njoints;
  const double w = 2.0 * M_PI * 0.1;
  ArmRun r;
  r.t.resize(n);
  r.q.resize(n, nj), r.v.resize(n, nj), r.a.resize(n, nj), r.tau.resize(n, nj);
  DynamicsData dd(model);
  State s = State::zero(model);
  for (int i = 0; i < n; ++i) {
    const double t = i / o.rate;
    r.t[i] = t;
    for (int j = 0; j < nj; ++j) {
      double q = motion[j].q0, v = 0.0, a = 0.0;
      for (size_t k = 0; k < motion[j].amplitude.size(); ++k) {
        const double wk = (k + 1) * w, A = motion[j].amplitude[k], arg = wk * t + motion[j].phase[k];
        q += A * std::sin(arg), v += A * wk * std::cos(arg), a -= A * wk * wk * std::sin(arg);
      }
      s.q[j] = q, s.v[j] = v, s.a[j] = a;
    }
    rnea(model, phi, dd, s);
    r.q.row(i) = s.q.transpose(), r.v.row(i) = s.v.transpose(), r.a.row(i) = s.a.transpose();
    r.tau.row(i) = (dd.tau + offset).transpose();
  }
  return r;
}

double rms(const Eigen::VectorXd& x) { return std::sqrt(x.squaredNorm() / std::max<Eigen::Index>(1, x.size())); }
}  // namespace

bool makeSyntheticArm(const SyntheticArmOptions& o, SyntheticArm& arm, std::string* error) {
  if (o.joints < 2 || o.joints > 9 || !(o.friction_ratio >= 0.0) || !(o.offset_ratio >= 0.0)) {
    if (error) *error = "synthetic arm: joints must be in [2, 9] and the ratios >= 0";
    return false;
  }
  Draw d(o.seed);
  std::ostringstream u;
  u << "<?xml version=\"1.0\"?>\n<robot name=\"synthetic_arm_" << o.seed << "\">\n  <link name=\"base\"/>\n";
  const double m0 = d.uniform(8.0, 15.0);
  // Joint placements first: a link's CoM lies between its origin and the next joint.
  std::vector<Eigen::Vector3d> place(o.joints + 1);
  std::vector<Eigen::Matrix3d> turn(o.joints + 1, Eigen::Matrix3d::Identity());
  place[0] = Eigen::Vector3d(0, 0, d.uniform(0.1, 0.3));
  for (int j = 1; j <= o.joints; ++j) {
    Eigen::Vector3d dir = Eigen::Vector3d::Zero();
    dir[d.integer(3)] = d.integer(2) ? 1.0 : -1.0;
    dir += 0.2 * Eigen::Vector3d(d.normal(), d.normal(), d.normal());
    place[j] = d.uniform(0.1, 0.45) * dir.normalized();
    const Eigen::Vector3d rpy(M_PI / 2 * d.integer(4) + d.uniform(-0.3, 0.3), M_PI / 2 * d.integer(4) + d.uniform(-0.3, 0.3),
                              M_PI / 2 * d.integer(4) + d.uniform(-0.3, 0.3));
    turn[j] = (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
               Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX())).toRotationMatrix();
  }
  for (int j = 0; j < o.joints; ++j) {
    const std::string link = "link" + std::to_string(j + 1), parent = j == 0 ? "base" : "link" + std::to_string(j);
    const Eigen::Vector3d rpy = turn[j].eulerAngles(2, 1, 0).reverse();  // URDF rpy: R = Rz(y) Ry(p) Rx(r)
    u << "  <joint name=\"joint" << j + 1 << "\" type=\"revolute\">\n    <parent link=\"" << parent
      << "\"/>\n    <child link=\"" << link << "\"/>\n    <origin xyz=\"" << vec(place[j]) << "\" rpy=\"" << vec(rpy)
      << "\"/>\n    <axis xyz=\"0 0 1\"/>\n    <limit lower=\"-2.9\" upper=\"2.9\" effort=\"1000\" velocity=\"3\"/>\n  </joint>\n";
    const double mass = m0 * std::pow(0.75, j) * d.uniform(0.7, 1.3);
    const Eigen::Vector3d com = (j + 1 < o.joints ? Eigen::Vector3d(0.5 * place[j + 1]) : Eigen::Vector3d::Zero()) +
                                0.05 * Eigen::Vector3d(d.uniform(-1, 1), d.uniform(-1, 1), d.uniform(-1, 1));
    const Eigen::Vector3d side(d.uniform(0.04, 0.3), d.uniform(0.04, 0.3), d.uniform(0.04, 0.3));
    const Eigen::Vector3d s2 = side.cwiseAbs2();
    const Eigen::Matrix3d R = randomRotation(d);
    const Eigen::Matrix3d I = R * (mass / 12.0 * Eigen::Vector3d(s2[1] + s2[2], s2[0] + s2[2], s2[0] + s2[1])).asDiagonal() * R.transpose();
    char b[512];
    std::snprintf(b, sizeof b,
                  "  <link name=\"%s\">\n    <inertial>\n      <origin xyz=\"%s\" rpy=\"0 0 0\"/>\n      <mass value=\"%.17g\"/>\n"
                  "      <inertia ixx=\"%.17g\" ixy=\"%.17g\" ixz=\"%.17g\" iyy=\"%.17g\" iyz=\"%.17g\" izz=\"%.17g\"/>\n"
                  "    </inertial>\n  </link>\n",
                  link.c_str(), vec(com).c_str(), mass, I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2), I(2, 2));
    u << b;
  }
  u << "</robot>\n";
  arm.urdf = u.str();
  if (!buildModelFromUrdfString(arm.urdf, false, arm.model, error)) return false;
  // Friction and offsets relative to each joint's rigid-body torque on a reference motion.
  ArmRunOptions ref;
  ref.seed = o.seed;
  Draw dm(o.seed ^ 0x5eedULL);
  const ArmRun r = exactRun(arm.model, arm.model.phi, Eigen::VectorXd::Zero(arm.model.njoints),
                            drawMotion(arm.model.njoints, ref, dm), ref);
  arm.truth = arm.model.phi;
  arm.offset = Eigen::VectorXd::Zero(arm.model.njoints);
  for (int j = 0; j < arm.model.njoints; ++j) {
    const double tau_rms = rms(r.tau.col(j)), v_rms = rms(r.v.col(j));
    const int f = arm.model.frictionParamIndex(j);
    arm.truth[f] = o.friction_ratio * d.uniform(0.5, 1.5) * tau_rms / v_rms;
    arm.truth[f + 1] = o.friction_ratio * d.uniform(0.5, 1.5) * tau_rms;
    arm.offset[j] = o.offset_ratio * d.uniform(-1.0, 1.0) * tau_rms;
  }
  return true;
}

ArmRun simulateArmRun(const SyntheticArm& arm, const ArmRunOptions& o) {
  Draw d(o.seed);
  const Model& model = arm.model;
  Eigen::VectorXd phi = arm.truth;
  if (o.payload > 0.0) phi[model.bodyParamIndex(model.nbodies - 1)] += o.payload;  // a point mass at the origin
  ArmRun r = exactRun(model, phi, arm.offset, drawMotion(model.njoints, o, d), o);
  for (int j = 0; j < model.njoints; ++j) {
    const double sigma = o.torque_noise * rms(r.tau.col(j));
    for (Eigen::Index i = 0; i < r.t.size(); ++i) {
      r.tau(i, j) += sigma * d.normal();
      r.q(i, j) += o.encoder_noise * d.normal();
      r.v(i, j) += o.velocity_noise * d.normal();
      r.a(i, j) += o.acceleration_noise * d.normal();
    }
  }
  return r;
}

bool writeArmRunCsv(const std::string& path, const Model& model, const ArmRun& r, std::string* error) {
  AtomicCsvWriter w;
  if (!w.open(path, error)) return false;
  std::fprintf(w.file(), "t");
  for (const char* k : {"q_", "v_", "a_", "tau_"})
    for (const std::string& n : model.joint_names) std::fprintf(w.file(), ",%s%s", k, n.c_str());
  std::fprintf(w.file(), "\n");
  for (Eigen::Index i = 0; i < r.t.size(); ++i) {
    std::fprintf(w.file(), "%.9g", r.t[i]);
    for (const Eigen::MatrixXd* m : {&r.q, &r.v, &r.a, &r.tau})
      for (int j = 0; j < model.njoints; ++j) std::fprintf(w.file(), ",%.12g", (*m)(i, j));
    std::fprintf(w.file(), "\n");
  }
  return w.commit(error);
}

}  // namespace exoid::tools
