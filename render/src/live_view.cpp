#include "exoid/render/live_view.hpp"

#include <GLFW/glfw3.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "exoid/estimator/dataset.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/lcm/lcm_endpoint.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/render/scene.hpp"

namespace exoid::render {

namespace {
// The latest state of every channel, folded into one FrameState (the last message of each wins, as in a render).
struct LiveState {
  explicit LiveState(const Model& m) : model(m), dyn(m) { frame.q = Eigen::VectorXd::Zero(m.njoints); }
  const Model& model;
  DynamicsData dyn;
  FrameState frame;
  EstimatorOutputSample estimate;
  bool have_truth = false, have_estimate = false;

  void onTruth(const GroundTruthSample& g) {
    frame.tick = g.tick, frame.t = 1e-3 * static_cast<double>(g.tick);
    frame.base_position = g.base_position, frame.base_orientation = g.base_orientation, frame.q = g.q;
    frame.com_true = g.com;
    have_truth = true;
    if (have_estimate) {  // the estimate's CoM at the current pose
      const State s = estimator::stateFromTruth(model, g);
      forwardKinematics(model, dyn.kin, s);
      centroidal(model, estimate.params, dyn);
      frame.has_estimate = dyn.com.allFinite();
      frame.com_estimate = s.base_position + s.base_orientation * dyn.com;
    }
  }
};

void subscribe(LcmEndpoint& ep, LiveState& st, const std::vector<std::string>& params, const std::vector<std::string>& coords) {
  ep.subscribe<exoid_lcm::ground_truth_t>(channels::kTruth, [&st](const char*, const exoid_lcm::ground_truth_t& m) {
    GroundTruthSample g;
    if (fromLcm(m, st.model.joint_names, g)) st.onTruth(g);
  });
  ep.subscribe<exoid_lcm::controller_status_t>(channels::kControllerStatus, [&st](const char*, const exoid_lcm::controller_status_t& m) {
    ControllerStatusSample s;
    if (!fromLcm(m, s)) return;
    st.frame.has_status = true, st.frame.com_ref = s.com_ref, st.frame.com_model = s.com;
  });
  ep.subscribe<exoid_lcm::estimator_output_t>(channels::kEstimate, [&st, params, coords](const char*, const exoid_lcm::estimator_output_t& m) {
    EstimatorOutputSample e;
    if (!fromLcm(m, params, kAnyNumBase, coords, e)) return;
    st.have_estimate = e.valid;
    if (e.valid) st.estimate = e;
    else st.frame.has_estimate = false;
  });
  for (int side = 0; side < 2; ++side)
    ep.subscribe<exoid_lcm::force_plate_t>(side ? channels::kPlateLeft : channels::kPlateRight,
                                           [&st, side](const char*, const exoid_lcm::force_plate_t& m) {
      ForcePlateSample p;
      if (!fromLcm(m, side, p)) return;
      Eigen::Vector3d force, moment;
      estimator::footWrenchFromPlate(p, force, moment);
      st.frame.force[side] = force, st.frame.loaded[side] = force.z() > kLoadedForce;
      st.frame.cop[side] = p.plate_position + p.plate_orientation * p.cop;
    });
}

// The window's loop: LCM messages as they come, a frame every 1 / fps s, until stop or the window closes.
void drawLoop(GLFWwindow* window, const RenderModel& rm, RenderData& rd, LcmEndpoint& ep, LiveState& st,
              const LiveViewOptions& o, const std::atomic<bool>& stop) {
  ViewCamera camera;
  viewCamera(o.view, camera);
  const auto period = std::chrono::duration<double>(1.0 / o.fps);
  auto next = std::chrono::steady_clock::now();
  while (!stop.load() && !glfwWindowShouldClose(window)) {
    const double left_ms = std::chrono::duration<double, std::milli>(next - std::chrono::steady_clock::now()).count();
    if (left_ms > 0 && ep.handleTimeout(static_cast<int>(left_ms) + 1) != 0) continue;  // a message: more may wait
    ep.handleAvailable();
    next = std::chrono::steady_clock::now() + std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    for (int k = 0; k < 4; ++k)  // keys 1-4 switch the camera
      if (glfwGetKey(window, GLFW_KEY_1 + k) == GLFW_PRESS) viewCamera(viewNames()[static_cast<size_t>(k)], camera);
    int w = 0, h = 0;
    glfwGetFramebufferSize(window, &w, &h);
    if (st.have_truth) drawFrame(rm, rd, st.frame, camera, w, h);
    glfwSwapBuffers(window);
    glfwPollEvents();
  }
}

// The thread: window, GL context, scene, subscription, loop. Problems are one line on stderr (the run goes on).
void runWindow(LiveViewOptions o, const std::atomic<bool>* stop) {
  std::string err;
  Model model;
  RenderModel rm;
  if (!buildModelFromUrdfFile(o.urdf_path, true, model, &err) ||
      !loadRenderModel(o.mjcf_path, model, o.scenario, o.width, o.height, rm, &err))
    return void(std::fprintf(stderr, "live view: %s\n", err.c_str()));
  if (!glfwInit()) return void(std::fprintf(stderr, "live view: GLFW cannot initialise (no usable display)\n"));
  glfwWindowHint(GLFW_SAMPLES, 4);
  GLFWwindow* window = glfwCreateWindow(o.width, o.height, "exoid live view (keys 1-4: front, side, back, iso)", nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    return void(std::fprintf(stderr, "live view: cannot open a window\n"));
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);
  {
    RenderData rd;
    std::unique_ptr<LcmEndpoint> ep = LcmEndpoint::create(o.lcm_url, &err);
    LiveState st(model);
    if (ep && makeRenderData(rm, rd, &err, true)) {
      subscribe(*ep, st, model.paramNames(), model.coordinateNames());
      drawLoop(window, rm, rd, *ep, st, o, *stop);
    } else {
      std::fprintf(stderr, "live view: %s\n", err.c_str());
    }
  }
  glfwDestroyWindow(window);
  glfwTerminate();
}
}  // namespace

std::string liveViewUnavailable() {
  const char* x = std::getenv("DISPLAY");
  const char* wl = std::getenv("WAYLAND_DISPLAY");
  if ((!x || !*x) && (!wl || !*wl)) return "no display (DISPLAY is not set): running without the live view";
  return "";
}

std::unique_ptr<LiveView> LiveView::start(const LiveViewOptions& options, std::string* why) {
  if (std::string no = liveViewUnavailable(); !no.empty()) return *why = no, nullptr;
  std::unique_ptr<LiveView> v(new LiveView());
  v->thread_ = std::thread(runWindow, options, &v->stop_);
  return v;
}

LiveView::~LiveView() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
}

}  // namespace exoid::render
