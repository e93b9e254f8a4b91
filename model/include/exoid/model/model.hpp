#pragma once
// The kinematic tree and its inertial parameters: a constant description (Model) built once from URDF,
// and per-thread scratch (Data) that the algorithms fill. Conventions: docs/conventions.md.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/StdVector>
#include <string>
#include <vector>

namespace exoid {

template <class T>
using AlignedVector = std::vector<T, Eigen::aligned_allocator<T>>;
using Vector10d = Eigen::Matrix<double, 10, 1>;
using Matrix6x10 = Eigen::Matrix<double, 6, 10>;

/// Number of standard inertial parameters per body: m, mcx, mcy, mcz, Ixx, Ixy, Ixz, Iyy, Iyz, Izz.
inline constexpr int kParamsPerBody = 10;
/// Number of friction parameters per joint: fv (viscous), fc (Coulomb).
inline constexpr int kParamsPerJoint = 2;
/// Names of the per-body parameters, in column order.
extern const char* const kBodyParamNames[kParamsPerBody];

enum class JointType { Revolute };

/// A kinematic tree of rigid bodies connected by 1-dof joints, optionally on a 6-dof floating base.
///
/// Bodies are the links that move: with a floating base body 0 is the root link (the base); with a fixed
/// base the root link is the world and is not a body. Links attached by fixed joints are lumped into their
/// parent. Bodies are numbered in tree order (depth-first, children in the order their joints appear in
/// the URDF file), so parent[b] < b. Every body except a floating base has exactly one joint, numbered
/// body - (floating_base ? 1 : 0).
struct Model {
  std::string name;
  bool floating_base = false;
  int nbodies = 0;  ///< moving bodies
  int njoints = 0;  ///< 1-dof joints
  int nv = 0;       ///< generalized velocities: 6 (if floating) + njoints

  std::vector<std::string> body_names;   ///< [nbodies] URDF link names
  std::vector<std::string> joint_names;  ///< [njoints] URDF joint names
  std::vector<int> parent;               ///< [nbodies] parent body, -1 for the root (base or world)
  std::vector<int> joint_body;           ///< [njoints] body moved by each joint
  std::vector<JointType> joint_type;     ///< [njoints]
  AlignedVector<Eigen::Matrix3d> tree_rotation;  ///< [nbodies] parent <- body at q = 0 (identity for a base)
  AlignedVector<Eigen::Vector3d> tree_position;  ///< [nbodies] body origin in parent coordinates at q = 0
  AlignedVector<Eigen::Vector3d> joint_axis;     ///< [nbodies] unit joint axis in body coordinates (0 for a base)
  std::vector<std::vector<int>> subtree;          ///< [nbodies] bodies in the subtree of each body, itself first
  Eigen::VectorXd position_lower, position_upper, effort_limit;  ///< [njoints] from URDF <limit> (inf / 0 if absent)

  /// Standard parameters phi = [phi_body0 ... phi_body(nb-1), fv_0, fc_0, ..., fv_(nj-1), fc_(nj-1)].
  Eigen::VectorXd phi;  ///< [nparams()]
  /// Gravity acceleration in world coordinates (root-link coordinates for a fixed base), m/s^2.
  Eigen::Vector3d gravity{0.0, 0.0, -9.81};

  /// URDF-derived frames that are not bodies (fixed-joint links), with their rigid placement on a body.
  struct Frame {
    std::string name;
    int body = -1;  ///< body the frame is attached to (-1: the fixed root / world)
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< body <- frame
    Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< frame origin in body coordinates
    /// This link's own URDF inertial as standard parameters in its body's coordinates: its share of the body's
    /// lumped parameters (zero without an inertial or on the fixed root), e.g. one wearer segment of a link.
    Vector10d phi = Vector10d::Zero();
    EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  };
  AlignedVector<Frame> frames;

  int nparams() const { return kParamsPerBody * nbodies + kParamsPerJoint * njoints; }
  int nInertialParams() const { return kParamsPerBody * nbodies; }
  int bodyParamIndex(int body) const { return kParamsPerBody * body; }
  int frictionParamIndex(int joint) const { return kParamsPerBody * nbodies + kParamsPerJoint * joint; }
  int jointOfBody(int body) const { return body - (floating_base ? 1 : 0); }  ///< -1 for a floating base
  int jointRow(int joint) const { return (floating_base ? 6 : 0) + joint; }   ///< row of K / index in v
  int bodyIndex(const std::string& name) const;   ///< -1 if absent
  int jointIndex(const std::string& name) const;  ///< -1 if absent
  int frameIndex(const std::string& name) const;  ///< -1 if absent
  /// Parameter names: "<link>.<param>" per body, then "<joint>.fv", "<joint>.fc".
  std::vector<std::string> paramNames() const;
  /// Generalized-coordinate names, one per row of K [nv]: floating base "base_nx", "base_ny", "base_nz",
  /// "base_fx", "base_fy", "base_fz" (moment then force, base coordinates), then the joint names.
  std::vector<std::string> coordinateNames() const;
  /// Total mass of the moving bodies, kg.
  double totalMass() const;
};

/// Motion of the system at one instant. Sizes: q, v, a are [njoints]. The base fields are ignored for a
/// fixed base. All base quantities refer to the base-link origin and are expressed in base coordinates.
struct State {
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< world <- base, Hamilton
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();   ///< base origin, world coordinates (not used by K)
  Eigen::Vector3d base_omega = Eigen::Vector3d::Zero();      ///< angular velocity, base coordinates
  Eigen::Vector3d base_velocity = Eigen::Vector3d::Zero();   ///< linear velocity of the origin, base coords
  Eigen::Vector3d base_domega = Eigen::Vector3d::Zero();     ///< angular acceleration, base coordinates
  Eigen::Vector3d base_acceleration = Eigen::Vector3d::Zero();  ///< classical linear acceleration of the
                                                                ///< origin, base coords, gravity excluded
  Eigen::VectorXd q, v, a;

  /// A zero state sized for the model.
  static State zero(const Model& model);
};

/// Scratch space for one thread: sized once by the constructor, never reallocated by the algorithms.
/// Kinematic quantities are expressed in the reference frame: the base frame for a floating base, the
/// root (world) frame for a fixed base.
struct Data {
  explicit Data(const Model& model);

  AlignedVector<Eigen::Matrix3d> R;      ///< [nbodies] reference <- body rotation
  AlignedVector<Eigen::Vector3d> p;      ///< [nbodies] body origin
  AlignedVector<Eigen::Vector3d> axis;   ///< [nbodies] joint axis (zero for a base)
  AlignedVector<Eigen::Vector3d> omega;  ///< [nbodies] angular velocity (inertial)
  AlignedVector<Eigen::Vector3d> vel;    ///< [nbodies] linear velocity of the body origin (inertial)
  AlignedVector<Eigen::Vector3d> alpha;  ///< [nbodies] angular acceleration (inertial)
  AlignedVector<Eigen::Vector3d> acc;    ///< [nbodies] classical acceleration of the origin minus gravity
  AlignedVector<Matrix6x10> body_regressor;  ///< [nbodies] wrench of each body about the reference origin,
                                             ///< [moment; force], as a linear map of its 10 parameters
  Eigen::MatrixXd K;  ///< [nv x nparams] joint torque regressor, filled by computeJointTorqueRegressor
};

}  // namespace exoid
