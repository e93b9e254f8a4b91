#pragma once
// MuJoCo's renderer on the simulator's own scene (the MJCF and the scenario's payloads), MuJoCo style: a
// constant RenderModel (loadRenderModel), a RenderData with the GL context, mjData and the scene
// (makeRenderData), and renderFrame, which draws one FrameState from one camera into an RGB image.
//
// Drawn on top of MuJoCo's own geoms (the exoskeleton's MJCF has geoms for the body and the soles only): the
// links as translucent capsules between successive link-frame origins, the payloads as spheres (their mass at 1000 kg/m^3)
// at their centres of mass, the four CoMs (legend in the image), their projections on the floor, and each
// plate's ground reaction as an arrow at its centre of pressure (kArrowMetresPerNewton). Colours: kColour*.
#include <mujoco/mujoco.h>

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "exoid/model/model.hpp"
#include "exoid/render/egl_context.hpp"
#include "exoid/render/run_frames.hpp"
#include "exoid/sim/sim.hpp"

namespace exoid::render {

using Rgb = std::array<float, 3>;
inline constexpr Rgb kColourLink = {0.30f, 0.50f, 0.80f};      ///< steel blue
inline constexpr Rgb kColourComTrue = {0.90f, 0.10f, 0.10f};   ///< red sphere
inline constexpr Rgb kColourComRef = {0.10f, 0.80f, 0.10f};    ///< green cross
inline constexpr Rgb kColourComModel = {0.95f, 0.85f, 0.10f};  ///< yellow horizontal disc
inline constexpr Rgb kColourComEstimate = {0.60f, 0.20f, 0.90f};  ///< purple upright disc
inline constexpr Rgb kColourPayload = {0.90f, 0.20f, 0.60f};   ///< pink
inline constexpr Rgb kColourWrench = {0.10f, 0.80f, 0.90f};    ///< cyan arrow
inline constexpr double kArrowMetresPerNewton = 1e-3;
inline constexpr double kLinkRadius = 0.02;    ///< m
inline constexpr float kLinkAlpha = 0.6f;      ///< translucent: the CoM markers inside the pelvis stay visible
inline constexpr double kComSphereRadius = 0.03;   ///< m, the true CoM
inline constexpr double kComDiscRadius = 0.045;     ///< m, the model's and the estimate's CoM

/// A free camera looking at `lookat` (MuJoCo's mjvCamera: azimuth and elevation in degrees; the camera sits at
/// lookat - distance * (cos e cos a, cos e sin a, sin e)); vertical field of view from the MJCF (visual/global).
struct ViewCamera {
  std::string name;
  Eigen::Vector3d lookat = Eigen::Vector3d(0.03, 0.0, 0.75);
  double distance = 3.0, azimuth = 180.0, elevation = -12.0;
};

/// The named views: front (from +x), side (from -y, the robot's right), back, iso (front right, from above).
/// False for an unknown name.
bool viewCamera(const std::string& name, ViewCamera& out);
const std::vector<std::string>& viewNames();

/// Constant part: the scene's model and what is drawn on it.
struct RenderModel {
  sim::SimModel sim;      ///< the simulator's MuJoCo model (simLoad: checked MJCF, scenario applied)
  int width = 640, height = 480;
  std::vector<int> joint_qpos;  ///< [model njoints] qpos address of each URDF joint (matched by name)
  std::vector<std::array<int, 2>> links;  ///< (parent, child) MuJoCo bodies drawn as a capsule between origins
  struct PayloadMark {
    int body = -1;
    Eigen::Vector3d com = Eigen::Vector3d::Zero();  ///< body frame
    double radius = 0.0;
    int64_t from_tick = 0;  ///< drawn from this tick on (timed payloads)
  };
  std::vector<PayloadMark> payloads;
};

/// Loads the MJCF with the scenario (payloads, harness) as the sim does; matches the URDF model's joints by
/// name. False with *err naming the file or the missing joint.
bool loadRenderModel(const std::string& mjcf_path, const Model& model, const sim::Scenario& scenario, int width,
                     int height, RenderModel& out, std::string* err);

/// Mutable part: the GL context (one per thread), mjData, the scene and the image of the last frame.
struct RenderData {
  EglContext gl;
  sim::MjOwned<mjData, mj_deleteData> d;
  mjvScene scene;
  mjrContext context;
  mjvOption option;
  bool made = false;
  std::vector<unsigned char> rgb;  ///< [height * width * 3] last frame, top row first
  RenderData();
  ~RenderData();
  RenderData(const RenderData&) = delete;
  RenderData& operator=(const RenderData&) = delete;
};

/// Creates MuJoCo's render context for `model`: offscreen, in a headless EGL context made here; or, with
/// `window` true, drawing into the window whose GL context the caller has made current (the live view).
/// False with *err (no EGL, ...).
bool makeRenderData(const RenderModel& model, RenderData& data, std::string* err, bool window = false);

/// Draws `frame` seen from `camera` into the current buffer (with the legend and the time, top left), in a
/// viewport of width x height pixels.
void drawFrame(const RenderModel& model, RenderData& data, const FrameState& frame, const ViewCamera& camera,
               int width, int height);

/// drawFrame offscreen at the model's size, then the pixels into data.rgb.
void renderFrame(const RenderModel& model, RenderData& data, const FrameState& frame, const ViewCamera& camera);

}  // namespace exoid::render
