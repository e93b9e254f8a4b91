// renderFrame (scene.hpp): pose the MuJoCo model, add the drawn geoms to MuJoCo's scene, render offscreen, read
// the pixels back (bottom row first in OpenGL; stored top row first).
#include <cstdio>
#include <cstring>

#include "exoid/render/scene.hpp"

namespace exoid::render {

namespace {
// A decor geom at the end of the scene (nullptr when the scene is full: that geom is left out).
mjvGeom* addGeom(mjvScene& s, int type, const Eigen::Vector3d& size, const Eigen::Vector3d& pos,
                 const Eigen::Matrix3d& rot, const Rgb& c, float alpha = 1.0f) {
  if (s.ngeom >= s.maxgeom) return nullptr;
  mjvGeom* g = s.geoms + s.ngeom++;
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> mat = rot;  // MuJoCo: row-major
  const float rgba[4] = {c[0], c[1], c[2], alpha};
  mjv_initGeom(g, type, size.data(), pos.data(), mat.data(), rgba);
  g->category = mjCAT_DECOR;
  g->emission = 0.3f;  // no specular highlight: the colour keeps its hue under the lights
  g->specular = 0.0f;
  return g;
}

// A capsule or arrow from a to b (skipped when shorter than 1 mm).
void addConnector(mjvScene& s, int type, double width, const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Rgb& c,
                  float alpha = 1.0f) {
  if ((b - a).norm() < 1e-3) return;
  if (mjvGeom* g = addGeom(s, type, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity(), c, alpha)) {
    mjv_makeConnector(g, type, width, a.x(), a.y(), a.z(), b.x(), b.y(), b.z());
    if (type == mjGEOM_ARROW) g->size[2] *= 2;  // MuJoCo 2.2 draws an arrow from a over size[2] = |b - a| / 2 only
  }
}

void addLinksAndPayloads(const RenderModel& model, const mjData* d, int64_t tick, mjvScene& s) {
  auto xpos = [&](int b) { return Eigen::Vector3d(d->xpos + 3 * b); };
  for (const auto& l : model.links) addConnector(s, mjGEOM_CAPSULE, kLinkRadius, xpos(l[0]), xpos(l[1]), kColourLink, kLinkAlpha);
  for (const RenderModel::PayloadMark& p : model.payloads) {
    if (p.body < 0 || tick < p.from_tick) continue;
    const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> R(d->xmat + 9 * p.body);
    addGeom(s, mjGEOM_SPHERE, Eigen::Vector3d::Constant(p.radius), xpos(p.body) + R * p.com, Eigen::Matrix3d::Identity(),
            kColourPayload);
  }
}

// The four CoMs (distinct shapes: each stays visible when they nearly coincide) and their floor projections.
void addComMarkers(const FrameState& f, mjvScene& s) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  // Floor projections as discs on the plates' top (z = 0), stacked and narrowing (true, reference, controller,
  // estimate), so that coinciding ones show as rings.
  int level = 0;
  auto floorDot = [&](const Eigen::Vector3d& c, const Rgb& colour) {
    const double radius = 0.035 - 0.007 * level, z = 0.001 + 0.002 * level++;
    addGeom(s, mjGEOM_CYLINDER, Eigen::Vector3d(radius, 0.001, 0.0), Eigen::Vector3d(c.x(), c.y(), z), I, colour);
  };
  addGeom(s, mjGEOM_SPHERE, Eigen::Vector3d::Constant(kComSphereRadius), f.com_true, I, kColourComTrue);
  floorDot(f.com_true, kColourComTrue);
  if (f.has_status) {
    for (int axis = 0; axis < 3; ++axis) {  // a 3-axis cross, 0.14 m wide
      Eigen::Vector3d half = Eigen::Vector3d::Constant(0.004);
      half[axis] = 0.07;
      addGeom(s, mjGEOM_BOX, half, f.com_ref, I, kColourComRef);
    }
    floorDot(f.com_ref, kColourComRef);
    addGeom(s, mjGEOM_CYLINDER, Eigen::Vector3d(kComDiscRadius, 0.004, 0.0), f.com_model, I, kColourComModel);
    floorDot(f.com_model, kColourComModel);
  }
  if (f.has_estimate) {
    const Eigen::Matrix3d upright = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
    addGeom(s, mjGEOM_CYLINDER, Eigen::Vector3d(kComDiscRadius, 0.004, 0.0), f.com_estimate, upright, kColourComEstimate);
    floorDot(f.com_estimate, kColourComEstimate);
  }
}

void addWrenchArrows(const FrameState& f, mjvScene& s) {
  for (int side = 0; side < 2; ++side)
    if (f.loaded[side])
      addConnector(s, mjGEOM_ARROW, 0.015, f.cop[side], f.cop[side] + kArrowMetresPerNewton * f.force[side], kColourWrench);
}

void drawLegend(const RenderData& data, const FrameState& f) {
  const mjrContext* con = &data.context;
  char time[64];
  std::snprintf(time, sizeof time, "t = %.2f s", f.t);
  mjr_text(mjFONT_NORMAL, time, con, 0.02f, 0.94f, 1.0f, 1.0f, 1.0f);
  struct Entry { const char* text; Rgb c; bool shown; };
  const Entry entries[] = {{"o  true CoM", kColourComTrue, true},
                           {"+  reference CoM", kColourComRef, f.has_status},
                           {"-  controller's CoM", kColourComModel, f.has_status},
                           {"|  online estimate's CoM", kColourComEstimate, f.has_estimate},
                           {"^  plate force at the CoP", kColourWrench, true}};
  float y = 0.88f;
  for (const Entry& e : entries) {
    const float k = e.shown ? 1.0f : 0.35f;  // dimmed: not in the log at this time
    mjr_text(mjFONT_NORMAL, e.text, con, 0.02f, y, k * e.c[0], k * e.c[1], k * e.c[2]);
    y -= 0.05f;
  }
}

void setPose(const RenderModel& model, mjData* d, const FrameState& f) {
  const mjModel* m = model.sim.m;
  std::memcpy(d->qpos, model.sim.qpos_init.data(), sizeof(mjtNum) * static_cast<size_t>(m->nq));
  const int b = model.sim.base_qpos;
  for (int i = 0; i < 3; ++i) d->qpos[b + i] = f.base_position[i];
  const Eigen::Quaterniond& q = f.base_orientation;
  d->qpos[b + 3] = q.w(), d->qpos[b + 4] = q.x(), d->qpos[b + 5] = q.y(), d->qpos[b + 6] = q.z();
  for (size_t j = 0; j < model.joint_qpos.size() && static_cast<Eigen::Index>(j) < f.q.size(); ++j)
    d->qpos[model.joint_qpos[j]] = f.q[static_cast<Eigen::Index>(j)];
  mj_kinematics(m, d);
}
}  // namespace

void drawFrame(const RenderModel& model, RenderData& data, const FrameState& frame, const ViewCamera& camera,
               int width, int height) {
  const mjModel* m = model.sim.m;
  setPose(model, data.d, frame);
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  cam.type = mjCAMERA_FREE;
  for (int i = 0; i < 3; ++i) cam.lookat[i] = camera.lookat[i];
  cam.distance = camera.distance, cam.azimuth = camera.azimuth, cam.elevation = camera.elevation;
  mjv_updateScene(m, data.d, &data.option, nullptr, &cam, mjCAT_ALL, &data.scene);
  addLinksAndPayloads(model, data.d, frame.tick, data.scene);
  addComMarkers(frame, data.scene);
  addWrenchArrows(frame, data.scene);
  const mjrRect viewport = {0, 0, width, height};
  mjr_render(viewport, &data.scene, &data.context);
  drawLegend(data, frame);
}

void renderFrame(const RenderModel& model, RenderData& data, const FrameState& frame, const ViewCamera& camera) {
  drawFrame(model, data, frame, camera, model.width, model.height);
  const mjrRect viewport = {0, 0, model.width, model.height};
  mjr_readPixels(data.rgb.data(), nullptr, viewport, &data.context);
  const size_t row = static_cast<size_t>(model.width) * 3;
  for (int r = 0; r < model.height / 2; ++r)  // OpenGL's bottom-up rows -> top-down
    std::swap_ranges(data.rgb.begin() + static_cast<long>(r * row), data.rgb.begin() + static_cast<long>((r + 1) * row),
                     data.rgb.begin() + static_cast<long>((model.height - 1 - r) * row));
}

}  // namespace exoid::render
