#pragma once
// The wearer strapped into the exoskeleton (docs/wearer.md "Mounting"): each wearer segment placed rigidly on the
// exoskeleton link it rides on, from the standing pose. Used by `exoid model wearer` (the prior URDF: segments as
// fixed links) and by the simulator (segments as welded MuJoCo bodies, the upper body on a lumbar joint).
//
// The placement rules: the wearer's hip, knee and ankle joint centres are the exoskeleton's hip flexion, knee and
// ankle dorsiflexion axis points (a fitted exoskeleton); thigh and shank CoMs lie on the line to the next exo joint
// at de Leva's fraction of the WEARER's segment length (a wearer longer or shorter than the exo's links keeps their
// own CoM distance from the proximal joint); the foot's CoM is in front of the ankle by (fraction - 0.22) x foot
// length, midway between the ankle axis and the sole; the head, trunk and arms stand upright above the mid-point of
// the hip axes as in standingSegmentCom. The lower trunk (OMPH-MIDH: the pelvis) rides on the exo's pelvis link;
// the head, upper and middle trunk and arms pivot about the lumbar point, at the navel (OMPH) height above MIDH.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "exoid/model/anthropometry.hpp"
#include "exoid/model/model.hpp"

namespace exoid {

/// Pose world <- link of an exoskeleton link in the standing pose (any world frame with z up, x forward).
struct LinkPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
};

/// The exoskeleton links the wearer rides on, standing. Arrays: [0] right, [1] left.
struct ExoStanding {
  LinkPose pelvis;                        ///< link "body"
  std::array<LinkPose, 2> thigh, shank;   ///< "<side>_thigh" (origin on the hip flexion axis), "<side>_shank" (knee)
  std::array<LinkPose, 2> ankle, foot;    ///< "<side>_ankle" (origin on the dorsiflexion axis), "<side>_foot"
  std::array<Eigen::Vector3d, 2> sole{};  ///< sole centre (frame / geom "<side>_sole"), on the ground
};

/// Names of the exo links above, as in config/exo.urdf and config/exo.xml.
const char* exoPelvisLink();
std::string exoLegLink(const char* part, int side);  ///< part "thigh", "shank", "ankle", "foot"; side -1 right, +1 left

/// One wearer segment on its exo link: inertial in the link's frame.
struct MountedSegment {
  std::string segment;  ///< BodySegment::name
  std::string link;     ///< exo link it rides on
  bool above_lumbar = false;  ///< head, upper/middle trunk, arms: on the lumbar joint in the sim, rigid in the prior
  double mass = 0.0;
  Eigen::Vector3d com = Eigen::Vector3d::Zero();             ///< link frame
  Eigen::Matrix3d inertia_com = Eigen::Matrix3d::Zero();     ///< about the CoM, link axes
};

struct WearerMount {
  std::vector<MountedSegment> segments;                    ///< one per BodySegment, same order
  Eigen::Vector3d lumbar_pivot = Eigen::Vector3d::Zero();  ///< pelvis link frame
};

/// Whether a segment of this kind is above the lumbar joint (head, upper and middle trunk, arms).
bool aboveLumbar(SegmentKind kind);

/// The prior URDF's link (a model's frame) of a wearer segment: "wearer_" + BodySegment::name ("wearer_right_thigh").
std::string wearerFrameName(const std::string& segment);

/// The massless frame "wearer_lumbar" that the prior URDF carries at the lumbar pivot, on the pelvis link.
std::string lumbarPivotFrame();

/// Places every segment of `wearer` on `exo` (rules above).
WearerMount mountWearer(const Wearer& wearer, const ExoStanding& exo);

/// The segments above the lumbar joint lumped into one rigid body (mass, CoM and inertia about the CoM, pelvis link
/// frame): the upper body that the sim puts on the lumbar joint.
MountedSegment lumpAboveLumbar(const WearerMount& mount);

/// The same upper body as a model holds it: the frames "wearer_<segment>" of the segments above the lumbar joint
/// on the pelvis link, lumped (`body`: pelvis link frame), and the lumbar pivot frame's position (`pivot`, pelvis
/// link frame). False, `body` and `pivot` untouched, where the model has no pivot frame on the pelvis link or no
/// mass above it (no wearer, or a URDF written before the pivot frame existed).
bool upperBodyFromModel(const Model& model, MountedSegment& body, Eigen::Vector3d& pivot);

}  // namespace exoid
