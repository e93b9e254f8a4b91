// The wearer's segments placed on the exoskeleton's links from the standing pose (rules: wearer_mount.hpp).
#include "exoid/model/wearer_mount.hpp"

#include "exoid/model/inertial.hpp"

namespace exoid {

bool aboveLumbar(SegmentKind k) {
  return k == SegmentKind::Head || k == SegmentKind::UpperTrunk || k == SegmentKind::MiddleTrunk ||
         k == SegmentKind::UpperArm || k == SegmentKind::Forearm || k == SegmentKind::Hand;
}

namespace {

// World CoM of a segment, standing, and the link it rides on (side index 0 right, 1 left).
Eigen::Vector3d worldCom(const Wearer& w, const BodySegment& s, const ExoStanding& exo, const Eigen::Vector3d& midh,
                         const LinkPose** link) {
  const size_t i = s.side > 0 ? 1 : 0;
  const double f = s.com_fraction, L = s.length;
  switch (s.kind) {
    case SegmentKind::Thigh:
      *link = &exo.thigh[i];
      return exo.thigh[i].p + f * L * (exo.shank[i].p - exo.thigh[i].p).normalized();
    case SegmentKind::Shank:
      *link = &exo.shank[i];
      return exo.shank[i].p + f * L * (exo.ankle[i].p - exo.shank[i].p).normalized();
    case SegmentKind::Foot: {
      *link = &exo.foot[i];
      Eigen::Vector3d c = exo.ankle[i].p + (f - kHeelToAnkleFraction) * L * Eigen::Vector3d::UnitX();
      c.z() = 0.5 * (exo.ankle[i].p.z() + exo.sole[i].z());
      return c;
    }
    default:
      *link = &exo.pelvis;
      return midh + standingSegmentCom(w, s);
  }
}

}  // namespace

const char* exoPelvisLink() { return "body"; }

std::string wearerFrameName(const std::string& segment) { return "wearer_" + segment; }

std::string lumbarPivotFrame() { return wearerFrameName("lumbar"); }

std::string exoLegLink(const char* part, int side) { return std::string(side < 0 ? "right_" : "left_") + part; }

WearerMount mountWearer(const Wearer& w, const ExoStanding& exo) {
  WearerMount out;
  const Eigen::Vector3d midh = 0.5 * (exo.thigh[0].p + exo.thigh[1].p);
  for (const BodySegment& s : w.segments) {
    const LinkPose* link = nullptr;
    const Eigen::Vector3d c = worldCom(w, s, exo, midh, &link);
    MountedSegment m;
    m.segment = s.name;
    m.above_lumbar = aboveLumbar(s.kind);
    m.link = link == &exo.pelvis ? exoPelvisLink()
             : s.kind == SegmentKind::Thigh ? exoLegLink("thigh", s.side)
             : s.kind == SegmentKind::Shank ? exoLegLink("shank", s.side)
                                            : exoLegLink("foot", s.side);
    m.mass = s.mass;
    // Principal axes = world axes in the standing pose (anatomical position); expressed in the link's axes.
    m.com = link->R.transpose() * (c - link->p);
    m.inertia_com = link->R.transpose() * s.inertia.asDiagonal() * link->R;
    out.segments.push_back(m);
  }
  const double lower = w.segments[static_cast<size_t>(w.index("lower_trunk"))].length;
  out.lumbar_pivot = exo.pelvis.R.transpose() * (midh + Eigen::Vector3d(0.0, 0.0, lower) - exo.pelvis.p);
  return out;
}

MountedSegment lumpAboveLumbar(const WearerMount& mount) {
  Vector10d phi = Vector10d::Zero();
  for (const MountedSegment& s : mount.segments)
    if (s.above_lumbar) phi += paramsFromInertial(s.mass, s.com, Eigen::Matrix3d::Identity(), s.inertia_com);
  InertialProperties p;
  MountedSegment out;
  out.segment = "upper_body";
  out.link = exoPelvisLink();
  out.above_lumbar = true;
  if (!inertialFromParams(phi, p)) return out;  // no segment above the lumbar joint: mass 0
  out.mass = p.mass;
  out.com = p.com;
  out.inertia_com = p.inertia_com;
  return out;
}

bool upperBodyFromModel(const Model& model, MountedSegment& body, Eigen::Vector3d& pivot) {
  const int pelvis = model.bodyIndex(exoPelvisLink());
  const int f = model.frameIndex(lumbarPivotFrame());
  if (pelvis < 0 || f < 0 || model.frames[static_cast<size_t>(f)].body != pelvis) return false;
  Vector10d phi = Vector10d::Zero();
  for (int k = 0; k < kNumSegmentKinds; ++k) {
    const SegmentKind kind = static_cast<SegmentKind>(k);
    if (!aboveLumbar(kind)) continue;
    for (int side : isBilateral(kind) ? std::vector<int>{-1, 1} : std::vector<int>{0}) {
      const int fr = model.frameIndex(wearerFrameName(segmentName(kind, side)));
      if (fr >= 0 && model.frames[static_cast<size_t>(fr)].body == pelvis) phi += model.frames[static_cast<size_t>(fr)].phi;
    }
  }
  InertialProperties p;
  if (!inertialFromParams(phi, p)) return false;
  body.segment = "upper_body";
  body.link = exoPelvisLink();
  body.above_lumbar = true;
  body.mass = p.mass;
  body.com = p.com;
  body.inertia_com = p.inertia_com;
  pivot = model.frames[static_cast<size_t>(f)].position;
  return true;
}

}  // namespace exoid
