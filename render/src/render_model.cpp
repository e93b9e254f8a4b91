// loadRenderModel, makeRenderData and the named views (scene.hpp).
#include <cmath>

#include "exoid/render/scene.hpp"

namespace exoid::render {

namespace {
constexpr double kPayloadDensity = 1000.0;  // kg/m^3: a payload drawn as a sphere of water of its mass
}  // namespace

const std::vector<std::string>& viewNames() {
  static const std::vector<std::string> names = {"front", "side", "back", "iso"};
  return names;
}

bool viewCamera(const std::string& name, ViewCamera& out) {
  out = ViewCamera();
  out.name = name;
  if (name == "front") return out.azimuth = 180.0, true;
  if (name == "side") return out.azimuth = 90.0, true;
  if (name == "back") return out.azimuth = 0.0, true;
  if (name == "iso") return out.azimuth = 215.0, out.elevation = -25.0, out.distance = 3.4, true;
  return false;
}

bool loadRenderModel(const std::string& mjcf_path, const Model& model, const sim::Scenario& scenario, int width,
                     int height, RenderModel& out, std::string* err) {
  if (!sim::simLoad(mjcf_path, sim::SensorConfig(), scenario, out.sim, err)) return false;
  mjModel* m = out.sim.m;
  out.width = width, out.height = height;
  m->vis.global.offwidth = width, m->vis.global.offheight = height;
  m->vis.headlight.ambient[0] = m->vis.headlight.ambient[1] = m->vis.headlight.ambient[2] = 0.3f;  // the MJCF's scene is dark
  m->vis.headlight.diffuse[0] = m->vis.headlight.diffuse[1] = m->vis.headlight.diffuse[2] = 0.6f;
  m->vis.quality.offsamples = 4;  // 4x MSAA: ~1.5x the cost of none with llvmpipe (docs/render.md)
  out.joint_qpos.assign(static_cast<size_t>(model.njoints), -1);
  for (int j = 0; j < model.njoints; ++j) {
    const int id = mj_name2id(m, mjOBJ_JOINT, model.joint_names[static_cast<size_t>(j)].c_str());
    if (id < 0 || m->jnt_type[id] != mjJNT_HINGE) {
      if (err) *err = mjcf_path + ": no hinge joint '" + model.joint_names[static_cast<size_t>(j)] + "' (the URDF model's)";
      return false;
    }
    out.joint_qpos[static_cast<size_t>(j)] = m->jnt_qposadr[id];
  }
  out.links.clear();
  for (int b = 1; b < m->nbody; ++b)
    if (m->body_parentid[b] != 0) out.links.push_back({m->body_parentid[b], b});
  out.payloads.clear();
  for (const sim::Payload& p : scenario.effects.payloads) {
    RenderModel::PayloadMark mark;
    mark.body = mj_name2id(m, mjOBJ_BODY, p.link.c_str());  // simLoad has checked the name
    mark.com = p.com;
    mark.radius = std::cbrt(3.0 * p.mass / (4.0 * M_PI * kPayloadDensity));
    mark.from_tick = static_cast<int64_t>(std::llround(p.attach_at_s / m->opt.timestep));
    out.payloads.push_back(mark);
  }
  return true;
}

RenderData::RenderData() {
  mjv_defaultScene(&scene);
  mjr_defaultContext(&context);
  mjv_defaultOption(&option);
}

RenderData::~RenderData() {
  if (!made) return;
  mjr_freeContext(&context);
  mjv_freeScene(&scene);
}

bool makeRenderData(const RenderModel& model, RenderData& data, std::string* err, bool window) {
  if (!window && !data.gl.create(err)) return false;
  const mjModel* m = model.sim.m;
  data.d = mj_makeData(m);
  if (!data.d) {
    if (err) *err = "MuJoCo could not allocate mjData";
    return false;
  }
  mjv_makeScene(m, &data.scene, 1000);
  mjr_makeContext(m, &data.context, mjFONTSCALE_150);
  data.made = true;
  mjr_setBuffer(window ? mjFB_WINDOW : mjFB_OFFSCREEN, &data.context);
  if (window) {
    data.scene.flags[mjRND_SHADOW] = 0;
    return true;
  }
  if (data.context.currentBuffer != mjFB_OFFSCREEN || data.context.offWidth < model.width ||
      data.context.offHeight < model.height) {
    if (err) *err = "MuJoCo's offscreen buffer is not available at the requested size";
    return false;
  }
  // Shadows cost ~3x the frame time in software rendering; the floor projections of the CoMs do their job.
  data.scene.flags[mjRND_SHADOW] = 0;
  data.scene.flags[mjRND_REFLECTION] = 0;
  data.scene.flags[mjRND_SKYBOX] = 0;
  data.rgb.assign(static_cast<size_t>(model.width) * static_cast<size_t>(model.height) * 3, 0);
  return true;
}

}  // namespace exoid::render
