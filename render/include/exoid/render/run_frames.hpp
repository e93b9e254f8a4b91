#pragma once
// What one rendered frame shows, sampled from a recorded run (the truth channel gives the pose): the frame
// at time t shows the last sample of each channel at or before tick round(t / 1 ms).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "exoid/intake/run_log.hpp"
#include "exoid/model/model.hpp"

namespace exoid::render {

/// One frame's state, world coordinates (docs/conventions.md).
struct FrameState {
  double t = 0.0;      ///< s (tick * 1 ms)
  int64_t tick = 0;    ///< tick of the truth sample shown
  Eigen::Vector3d base_position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond base_orientation = Eigen::Quaterniond::Identity();  ///< world <- base
  Eigen::VectorXd q;   ///< [njoints] model joint order
  Eigen::Vector3d com_true = Eigen::Vector3d::Zero();  ///< the simulated robot's CoM (payloads included)
  bool has_status = false;  ///< a controller status at or before the tick: com_ref and com_model are set
  Eigen::Vector3d com_ref = Eigen::Vector3d::Zero();    ///< the controller's CoM reference
  Eigen::Vector3d com_model = Eigen::Vector3d::Zero();  ///< the controller's CoM (its model's, or the blend)
  bool has_estimate = false;  ///< a valid online estimate at or before the tick: com_estimate is set
  Eigen::Vector3d com_estimate = Eigen::Vector3d::Zero();  ///< CoM of the estimate's parameters at this pose
  std::array<bool, 2> loaded{};  ///< [right, left] plate carries more than kLoadedForce
  std::array<Eigen::Vector3d, 2> cop{};    ///< centre of pressure on the plate's top surface, world
  std::array<Eigen::Vector3d, 2> force{};  ///< force ON the foot (ground reaction), world, N
};

inline constexpr double kLoadedForce = 5.0;  ///< N: a plate below this draws no arrow (its CoP is undefined)

/// Frame times: from `from_s` to `to_s` (both clamped to the run; to_s < 0: the run's end) every 1 / fps s.
struct FrameTimes {
  double fps = 30.0;
  double from_s = 0.0;
  double to_s = -1.0;
};

/// The frames of `log` at `times`. model: the URDF model (the estimate's CoM is centroidal(model, phi) at the
/// truth pose). False with *err when the log has no truth sample (EXO_TRUTH) or the window holds no frame.
bool sampleRunFrames(const Model& model, const intake::RunLog& log, const FrameTimes& times,
                     std::vector<FrameState>& frames, std::string* err);

/// Index of the frame of largest horizontal distance between the true CoM and its position in frame 0 (the
/// "largest CoM excursion" of a keyframe strip). frames must not be empty.
size_t largestComExcursion(const std::vector<FrameState>& frames);

}  // namespace exoid::render
