// The exoskeleton URDF plus the wearer's segments as fixed links (exoid model wearer).
#include "exoid/tools/wearer_urdf.hpp"

#include <cstdio>
#include <fstream>
#include <sstream>

#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"

namespace exoid::tools {

bool exoStandingFromModel(const Model& exo, ExoStanding& out, std::string* err) {
  DynamicsData dyn(exo);
  forwardKinematics(exo, dyn.kin, State::zero(exo));
  auto pose = [&](const std::string& name, LinkPose& p) {
    const int b = exo.bodyIndex(name);
    if (b < 0) {
      if (err) *err = "the exoskeleton model has no link '" + name + "' (the wearer rides on it)";
      return false;
    }
    p.R = dyn.kin.R[static_cast<size_t>(b)];
    p.p = dyn.kin.p[static_cast<size_t>(b)];
    return true;
  };
  if (!pose(exoPelvisLink(), out.pelvis)) return false;
  for (int i = 0; i < 2; ++i) {
    const int side = i == 0 ? -1 : 1;
    const size_t k = static_cast<size_t>(i);
    if (!pose(exoLegLink("thigh", side), out.thigh[k]) || !pose(exoLegLink("shank", side), out.shank[k]) ||
        !pose(exoLegLink("ankle", side), out.ankle[k]) || !pose(exoLegLink("foot", side), out.foot[k]))
      return false;
    const std::string sole = exoLegLink("sole", side);
    const int f = exo.frameIndex(sole);
    if (f < 0 || exo.frames[static_cast<size_t>(f)].body < 0) {
      if (err) *err = "the exoskeleton model has no frame '" + sole + "' on a moving link";
      return false;
    }
    const Model::Frame& fr = exo.frames[static_cast<size_t>(f)];
    out.sole[k] = dyn.kin.p[static_cast<size_t>(fr.body)] + dyn.kin.R[static_cast<size_t>(fr.body)] * fr.position;
  }
  return true;
}

bool writeWearerUrdf(const std::string& urdf_in, const WearerMount& mount, const std::string& urdf_out,
                     std::string* err) {
  std::ifstream in(urdf_in);
  if (!in) {
    if (err) *err = "cannot read '" + urdf_in + "'";
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  const size_t end = text.rfind("</robot>");
  if (end == std::string::npos) {
    if (err) *err = "'" + urdf_in + "' has no </robot>";
    return false;
  }
  std::string add = "\n  <!-- The wearer (exoid model wearer, docs/wearer.md): de Leva 1996 segments -->\n";
  for (const MountedSegment& s : mount.segments) {
    const Eigen::Matrix3d& I = s.inertia_com;
    const std::string name = wearerFrameName(s.segment);
    char buf[1024];
    std::snprintf(buf, sizeof buf,
                  "  <link name=\"%s\">\n    <inertial>\n      <origin xyz=\"%.17g %.17g %.17g\" rpy=\"0 0 0\"/>\n"
                  "      <mass value=\"%.17g\"/>\n"
                  "      <inertia ixx=\"%.17g\" ixy=\"%.17g\" ixz=\"%.17g\" iyy=\"%.17g\" iyz=\"%.17g\""
                  " izz=\"%.17g\"/>\n"
                  "    </inertial>\n  </link>\n"
                  "  <joint name=\"%s_mount\" type=\"fixed\"><parent link=\"%s\"/><child link=\"%s\"/>"
                  "<origin xyz=\"0 0 0\" rpy=\"0 0 0\"/></joint>\n",
                  name.c_str(), s.com.x(), s.com.y(), s.com.z(), s.mass, I(0, 0), I(0, 1), I(0, 2), I(1, 1), I(1, 2),
                  I(2, 2), name.c_str(), s.link.c_str(), name.c_str());
    add += buf;
  }
  // Massless: where the upper body turns on the pelvis in a person (the CoM observer's lever, com_observer.hpp).
  char pivot[512];
  const Eigen::Vector3d& o = mount.lumbar_pivot;
  const std::string lumbar = lumbarPivotFrame();
  std::snprintf(pivot, sizeof pivot,
                "  <link name=\"%s\"/>\n"
                "  <joint name=\"%s_mount\" type=\"fixed\"><parent link=\"%s\"/><child link=\"%s\"/>"
                "<origin xyz=\"%.17g %.17g %.17g\" rpy=\"0 0 0\"/></joint>\n",
                lumbar.c_str(), lumbar.c_str(), exoPelvisLink(), lumbar.c_str(), o.x(), o.y(), o.z());
  add += pivot;
  text.insert(end, add);
  AtomicCsvWriter out;  // atomic text file (the writer is not CSV-specific)
  if (!out.open(urdf_out, err)) return false;
  std::fputs(text.c_str(), out.file());
  return out.commit(err);
}

bool writeWearerPrior(const std::string& exo_urdf, const WearerSpec& spec, const std::string& urdf_out,
                      WearerMount* mount, std::string* err) {
  Model exo;
  ExoStanding standing;
  Wearer wearer;
  if (!buildModelFromUrdfFile(exo_urdf, true, exo, err) || !exoStandingFromModel(exo, standing, err) ||
      !buildWearer(spec, wearer, err))
    return false;
  const WearerMount m = mountWearer(wearer, standing);
  if (!writeWearerUrdf(exo_urdf, m, urdf_out, err)) return false;
  if (mount) *mount = m;
  return true;
}

}  // namespace exoid::tools
