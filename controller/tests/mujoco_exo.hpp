#pragma once
// A minimal in-process MuJoCo loop on config/exo.xml for the controller tests and benchmark (no LCM): sensors
// are read from qpos/qvel (optionally with noise), commands go to the motors.
#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <random>
#include <string>
#include <vector>

#include "controller_test_util.hpp"
#include "exoid/samples.hpp"

namespace exoid::controller::testing {

/// One-sigma white noise added to the sensors (config/sensors.yaml has the simulator's realistic values).
struct SensorNoise {
  double encoder = 0.0;  ///< rad
  double gyro = 0.0;     ///< rad/s per axis
  Eigen::Vector3d orientation = Eigen::Vector3d::Zero();  ///< rad, small rotation about world x, y, z
};

/// config/sensors.yaml's realistic noise (encoder 9e-6 rad, gyro 3.6e-3 rad/s, orientation 3.5/3.5/17.5 mrad).
inline SensorNoise realisticNoise() {
  SensorNoise n;
  n.encoder = 9.0e-6;
  n.gyro = 3.6e-3;
  n.orientation = Eigen::Vector3d(0.0035, 0.0035, 0.0175);
  return n;
}

/// The MuJoCo robot of config/exo.xml driven sample by sample.
class MujocoExo {
 public:
  ~MujocoExo() {
    if (d_) mj_deleteData(d_);
    if (m_) mj_deleteModel(m_);
  }

  bool load(const Model& model, std::string* error) {
    char err[1000] = "";
    m_ = mj_loadXML(configPath("exo.xml").c_str(), nullptr, err, sizeof(err));
    if (!m_) {
      *error = err;
      return false;
    }
    d_ = mj_makeData(m_);
    base_body_ = mj_name2id(m_, mjOBJ_BODY, "body");
    const int base_joint = m_->body_jntadr[base_body_];
    base_qpos_ = m_->jnt_qposadr[base_joint];
    base_dof_ = m_->jnt_dofadr[base_joint];
    for (int j = 0; j < model.njoints; ++j) {
      const int id = mj_name2id(m_, mjOBJ_JOINT, model.joint_names[static_cast<size_t>(j)].c_str());
      if (id < 0) {
        *error = "exo.xml has no joint " + model.joint_names[static_cast<size_t>(j)];
        return false;
      }
      qpos_adr_.push_back(m_->jnt_qposadr[id]);
      dof_adr_.push_back(m_->jnt_dofadr[id]);
      actuator_.push_back(mj_name2id(m_, mjOBJ_ACTUATOR, model.joint_names[static_cast<size_t>(j)].c_str()));
    }
    sole_site_[0] = mj_name2id(m_, mjOBJ_SITE, "right_sole");
    sole_site_[1] = mj_name2id(m_, mjOBJ_SITE, "left_sole");
    njoints_ = model.njoints;
    mj_forward(m_, d_);
    return base_body_ >= 0 && sole_site_[0] >= 0 && sole_site_[1] >= 0;
  }

  /// Sizes a sample for this robot (setup).
  void sizeState(RobotStateSample& s) const {
    s.q = Eigen::VectorXd::Zero(njoints_);
    s.tau = Eigen::VectorXd::Zero(njoints_);
    s.has_tau = Eigen::Matrix<bool, Eigen::Dynamic, 1>::Constant(njoints_, true);
    for (int j = 0; j < njoints_; ++j) s.has_tau[j] = actuator_[static_cast<size_t>(j)] >= 0;
  }

  /// Sensors of the current state (call after mj_step1), with Gaussian noise.
  void sample(RobotStateSample& s, int64_t tick, const SensorNoise& noise) {
    s.tick = tick;
    s.utime = static_cast<int64_t>(std::llround(d_->time * 1e6));
    for (int j = 0; j < njoints_; ++j) {
      s.q[j] = d_->qpos[qpos_adr_[static_cast<size_t>(j)]];
      if (noise.encoder > 0.0) s.q[j] += noise.encoder * normal_(rng_);
      const int a = actuator_[static_cast<size_t>(j)];
      s.tau[j] = a >= 0 ? d_->ctrl[a] : 0.0;
    }
    const mjtNum* qb = d_->qpos + base_qpos_;
    s.imu_orientation = Eigen::Quaterniond(qb[3], qb[4], qb[5], qb[6]);
    if (noise.orientation.squaredNorm() > 0.0) {
      const Eigen::Vector3d r(noise.orientation.x() * normal_(rng_), noise.orientation.y() * normal_(rng_),
                              noise.orientation.z() * normal_(rng_));
      const double angle = r.norm();
      if (angle > 0.0) s.imu_orientation = Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle)) * s.imu_orientation;
    }
    const mjtNum* vb = d_->qvel + base_dof_;
    s.imu_gyro = Eigen::Vector3d(vb[3], vb[4], vb[5]);  // free joint: angular velocity in the body frame
    if (noise.gyro > 0.0)
      for (int i = 0; i < 3; ++i) s.imu_gyro[i] += noise.gyro * normal_(rng_);
    s.imu_accel.setZero();
  }

  void apply(const JointCommandSample& c) {
    for (int j = 0; j < njoints_; ++j) {
      const int a = actuator_[static_cast<size_t>(j)];
      if (a >= 0) d_->ctrl[a] = c.tau[j];
    }
  }

  Eigen::Vector3d com() const { return Eigen::Map<const Eigen::Vector3d>(d_->subtree_com + 3 * base_body_); }
  Eigen::Vector3d solePosition(int foot) const {
    return Eigen::Map<const Eigen::Vector3d>(d_->site_xpos + 3 * sole_site_[foot]);
  }
  double baseHeight() const { return d_->qpos[base_qpos_ + 2]; }
  void setJoint(int joint, double value) { d_->qpos[qpos_adr_[static_cast<size_t>(joint)]] = value; }
  void setBaseHeight(double z) { d_->qpos[base_qpos_ + 2] = z; }
  void forward() { mj_forward(m_, d_); }
  void step1() { mj_step1(m_, d_); }
  void step2() { mj_step2(m_, d_); }
  mjModel* model() { return m_; }
  mjData* data() { return d_; }

 private:
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
  int base_body_ = -1, base_qpos_ = -1, base_dof_ = -1, njoints_ = 0;
  int sole_site_[2] = {-1, -1};
  std::vector<int> qpos_adr_, dof_adr_, actuator_;
  std::mt19937_64 rng_{12345};
  std::normal_distribution<double> normal_{0.0, 1.0};
};

}  // namespace exoid::controller::testing
