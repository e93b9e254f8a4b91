#pragma once
// The plain C++ expansion of the message schema (exoid/interfaces/schema.h): the member of each KIND, and the
// types the rows name (CommandMode, QpStatus, Vector6d). The structs themselves: exoid/samples.hpp and
// exoid/status_samples.hpp.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>

#include "exoid/interfaces/schema.h"

namespace exoid {

using Vector6d = Eigen::Matrix<double, 6, 1>;

/// joint_command_t.mode (EXOID_MODE_* in the plugin ABI).
enum class CommandMode : int8_t { Torque = 0, HoldLastSafe = 1, Damping = 2, Off = 3 };

/// Outcome of the controller's QP in one tick (controller_status_t.qp_status).
enum class QpStatus : int8_t { Solved = 0, MaxIterations = 1, Infeasible = 2, NotRun = 3 };

}  // namespace exoid

// One member of a plain struct per schema row (ABI_I32 rows: none). Vectors sized on setup (resize once), so
// filling a sample in a loop does not allocate.
#define EXOID_PLAIN_MEMBER(KIND, name, init, abi) EXOID_PLAIN_MEMBER_##KIND(name, init)
#define EXOID_PLAIN_MEMBER_I64(name, init) int64_t name = init;
#define EXOID_PLAIN_MEMBER_I32(name, init) int32_t name = init;
#define EXOID_PLAIN_MEMBER_F64(name, init) double name = init;
#define EXOID_PLAIN_MEMBER_BOOL(name, init) bool name = init;
#define EXOID_PLAIN_MEMBER_MODE(name, init) CommandMode name = init;
#define EXOID_PLAIN_MEMBER_QP(name, init) QpStatus name = init;
#define EXOID_PLAIN_MEMBER_PLATE(name, init) int name = init;
#define EXOID_PLAIN_MEMBER_V3(name, init) Eigen::Vector3d name = Eigen::Vector3d::Zero();
#define EXOID_PLAIN_MEMBER_V6(name, init) Vector6d name = Vector6d::Zero();
#define EXOID_PLAIN_MEMBER_QUAT(name, init) Eigen::Quaterniond name = Eigen::Quaterniond::Identity();
#define EXOID_PLAIN_MEMBER_JOINTS(name, init) Eigen::VectorXd name;
#define EXOID_PLAIN_MEMBER_JFLAGS(name, init) Eigen::Matrix<bool, Eigen::Dynamic, 1> name;
#define EXOID_PLAIN_MEMBER_VECX(name, init) Eigen::VectorXd name;
#define EXOID_PLAIN_MEMBER_FEET3(name, init) std::array<Eigen::Vector3d, 2> name;
#define EXOID_PLAIN_MEMBER_ABI_I32(name, init)
