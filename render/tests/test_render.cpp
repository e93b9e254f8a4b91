// exoid render (issue 22), headless (EGL, no display):
//  - a frame of a known pose has the links' colour where a pinhole projection of the link origins says, computed
//    here from the camera parameters and exoid's own forward kinematics of the URDF (not MuJoCo's camera or
//    xpos), and not where the same links would be in another pose;
//  - each CoM marker and the plate-force arrow at its projected position, in its colour; a marker with nothing
//    behind it in the log is not drawn;
//  - a damaged log is refused (exit 3, nothing written) unless --allow-partial; an intact one gives one PNG
//    per 1 / fps of the run;
//  - what a frame shows: the last sample of each channel at or before its tick, the estimate's CoM against MuJoCo;
//  - the reports' keyframe strips (writeRunKeyframes) are exoid render's, byte for byte;
//  - exo_sim --view without a display: one line, and the run goes on.
#include <gtest/gtest.h>
#include <lcm/eventlog.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/channels.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/render/run_keyframes.hpp"
#include "exoid/render/scene.hpp"
#include "support/run_command.hpp"

namespace exoid {
namespace {

std::string config(const std::string& f) { return std::string(EXOID_CONFIG_DIR) + "/" + f; }

// Pinhole projection of a world point for a free camera (azimuth/elevation/distance about lookat, vertical field
// of view fovy): pixel (column, row), row 0 at the top.
Eigen::Vector2d project(const render::ViewCamera& c, double fovy_deg, int w, int h, const Eigen::Vector3d& p) {
  const double a = c.azimuth * M_PI / 180, e = c.elevation * M_PI / 180;
  const Eigen::Vector3d fwd(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
  const Eigen::Vector3d up(-std::sin(e) * std::cos(a), -std::sin(e) * std::sin(a), std::cos(e));
  const Eigen::Vector3d right = fwd.cross(up), d = p - (c.lookat - c.distance * fwd);
  const double f = 0.5 * h / std::tan(0.5 * fovy_deg * M_PI / 180);
  return {0.5 * w + f * d.dot(right) / d.dot(fwd), 0.5 * h - f * d.dot(up) / d.dot(fwd)};
}

// Hue in degrees [0, 360) and saturation of an RGB pixel.
void hueSat(const unsigned char* px, double& hue, double& sat) {
  const double r = px[0] / 255.0, g = px[1] / 255.0, b = px[2] / 255.0;
  const double mx = std::max({r, g, b}), mn = std::min({r, g, b}), c = mx - mn;
  sat = mx > 0 ? c / mx : 0;
  if (c <= 0) return void(hue = 0);
  if (mx == r) hue = 60 * std::fmod((g - b) / c + 6, 6.0);
  else if (mx == g) hue = 60 * ((b - r) / c + 2);
  else hue = 60 * ((r - g) / c + 4);
}

double hueOf(const render::Rgb& c) {
  const unsigned char px[3] = {static_cast<unsigned char>(255 * c[0]), static_cast<unsigned char>(255 * c[1]),
                               static_cast<unsigned char>(255 * c[2])};
  double h, s;
  hueSat(px, h, s);
  return h;
}

// Pixels of the 3x3 block around `at` whose hue is within 15 degrees of `colour`'s (saturated, lit).
int colouredPixels(const render::RenderModel& m, const std::vector<unsigned char>& rgb, const Eigen::Vector2d& at,
                   const render::Rgb& colour) {
  int n = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const int x = static_cast<int>(std::lround(at.x())) + dx, y = static_cast<int>(std::lround(at.y())) + dy;
      if (x < 0 || y < 0 || x >= m.width || y >= m.height) continue;
      double h, s;
      hueSat(&rgb[(static_cast<size_t>(y) * static_cast<size_t>(m.width) + static_cast<size_t>(x)) * 3], h, s);
      const double dh = std::fabs(h - hueOf(colour));
      if (s > 0.3 && std::min(dh, 360 - dh) < 15) ++n;
    }
  return n;
}

class Render : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    std::string err;
    ASSERT_TRUE(buildModelFromUrdfFile(config("exo.urdf"), true, model_, &err)) << err;
    ASSERT_TRUE(render::loadRenderModel(config("exo.xml"), model_, sim::Scenario(), 640, 480, rmodel_, &err)) << err;
    ASSERT_TRUE(render::makeRenderData(rmodel_, rdata_, &err)) << err;
  }
  // A leaning, crouching pose: base rolled and pitched, right leg flexed, left leg abducted.
  static render::FrameState pose(bool bent) {
    render::FrameState f;
    f.base_position = Eigen::Vector3d(0.02, 0.01, bent ? 0.95 : 1.04);
    f.base_orientation = bent ? Eigen::Quaterniond(Eigen::AngleAxisd(0.12, Eigen::Vector3d(1, 0.5, 0).normalized()))
                              : Eigen::Quaterniond::Identity();
    f.q = Eigen::VectorXd::Zero(model_.njoints);
    if (bent)
      for (int j = 0; j < model_.njoints; ++j) {
        const std::string& n = model_.joint_names[static_cast<size_t>(j)];
        if (n.find("right") == 0 && n.find("hip_flexion") != std::string::npos) f.q[j] = 0.6;
        if (n.find("right") == 0 && n.find("knee") != std::string::npos) f.q[j] = 1.0;
        if (n.find("left") == 0 && n.find("hip_abduction") != std::string::npos) f.q[j] = -0.25;
        if (n.find("left") == 0 && n.find("hip_flexion") != std::string::npos) f.q[j] = -0.3;
        if (n.find("left") == 0 && n.find("knee") != std::string::npos) f.q[j] = 0.5;
      }
    f.com_true = Eigen::Vector3d(0.0, 0.0, 2.5);  // out of view: the link test sees links only
    return f;
  }
  // World positions of every moving body's origin (exoid's forward kinematics of the URDF).
  static std::vector<Eigen::Vector3d> linkOrigins(const render::FrameState& f) {
    Data kin(model_);
    State s = State::zero(model_);
    s.base_orientation = f.base_orientation, s.base_position = f.base_position, s.q = f.q;
    forwardKinematics(model_, kin, s);
    std::vector<Eigen::Vector3d> p;
    for (int b = 0; b < model_.nbodies; ++b) p.push_back(f.base_position + f.base_orientation * kin.p[static_cast<size_t>(b)]);
    return p;
  }
  double fovy() const { return rmodel_.sim.m->vis.global.fovy; }
  static inline Model model_;
  static inline render::RenderModel rmodel_;
  static inline render::RenderData rdata_;
};

double distanceToSegment(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const double t = std::clamp((p - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-12), 0.0, 1.0);
  return (p - (a + t * (b - a))).norm();
}

TEST_F(Render, LinksAreWhereTheProjectionOfTheirOriginsSays) {
  const render::FrameState bent = pose(true), straight = pose(false);
  const auto posed = linkOrigins(bent), other = linkOrigins(straight);
  for (const char* name : {"front", "side", "iso"}) {
    render::ViewCamera cam;
    ASSERT_TRUE(render::viewCamera(name, cam));
    render::renderFrame(rmodel_, rdata_, bent, cam);
    std::vector<Eigen::Vector2d> px;
    for (const auto& p : posed) px.push_back(project(cam, fovy(), 640, 480, p));
    for (int b = 1; b < model_.nbodies; ++b) {  // the base origin sits in the (translucent) body box
      // From the side (the robot's right) the left leg is behind the right one.
      if (std::string(name) == "side" && model_.body_names[static_cast<size_t>(b)].rfind("left", 0) == 0) continue;
      EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, px[static_cast<size_t>(b)], render::kColourLink), 5)
          << name << " view, link " << model_.body_names[static_cast<size_t>(b)] << " at " << px[static_cast<size_t>(b)].transpose();
    }
    // The straight pose's link origins that lie far from every drawn link of the bent pose: background there.
    int checked = 0;
    for (int b = 1; b < model_.nbodies; ++b) {
      const Eigen::Vector2d q = project(cam, fovy(), 640, 480, other[static_cast<size_t>(b)]);
      double nearest = 1e9;
      for (int c = 1; c < model_.nbodies; ++c)
        nearest = std::min(nearest, distanceToSegment(q, px[static_cast<size_t>(model_.parent[static_cast<size_t>(c)] < 0 ? 0 : model_.parent[static_cast<size_t>(c)])], px[static_cast<size_t>(c)]));
      if (nearest < 25) continue;
      ++checked;
      EXPECT_EQ(colouredPixels(rmodel_, rdata_.rgb, q, render::kColourLink), 0) << name << " view, straight-pose link "
                                                                                << model_.body_names[static_cast<size_t>(b)];
    }
    EXPECT_GE(checked, 2) << name << " view: the two poses must differ on screen";
  }
}

TEST_F(Render, MarkersAndArrowsAreAtTheirProjectedPositions) {
  render::FrameState f = pose(false);
  f.com_true = Eigen::Vector3d(0.35, -0.3, 0.75);
  f.com_ref = Eigen::Vector3d(0.35, 0.3, 0.75);
  f.com_model = Eigen::Vector3d(0.35, -0.45, 0.35);
  f.com_estimate = Eigen::Vector3d(0.35, 0.45, 0.35);
  f.has_status = f.has_estimate = true;
  f.loaded = {true, false};
  f.cop[0] = Eigen::Vector3d(0.25, -0.11, 0.0);
  f.force[0] = Eigen::Vector3d(0.0, 0.0, 400.0);
  render::ViewCamera cam;
  ASSERT_TRUE(render::viewCamera("front", cam));
  render::renderFrame(rmodel_, rdata_, f, cam);
  auto at = [&](const Eigen::Vector3d& p) { return project(cam, fovy(), 640, 480, p); };
  EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, at(f.com_true), render::kColourComTrue), 7);
  EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, at(f.com_ref), render::kColourComRef), 7);
  EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, at(f.com_model), render::kColourComModel), 3);  // a thin disc, seen edge-on
  EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, at(f.com_estimate), render::kColourComEstimate), 7);
  for (double z : {0.1, 0.2, 0.3, 0.35})  // the arrow's shaft, 1 mm per N: 0.4 m for 400 N
    EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, at(f.cop[0] + Eigen::Vector3d(0, 0, z)), render::kColourWrench), 3) << z;
  EXPECT_EQ(colouredPixels(rmodel_, rdata_.rgb, at(f.cop[0] + Eigen::Vector3d(0, 0, 0.5)), render::kColourWrench), 0)
      << "the arrow ends at 400 N x 1 mm/N";
  render::ViewCamera iso;  // from above: the floor projections are flat discs
  ASSERT_TRUE(render::viewCamera("iso", iso));
  render::renderFrame(rmodel_, rdata_, f, iso);
  EXPECT_GE(colouredPixels(rmodel_, rdata_.rgb, project(iso, fovy(), 640, 480, Eigen::Vector3d(f.com_true.x(), f.com_true.y(), 0.0)),
                           render::kColourComTrue), 5)
      << "floor projection of the true CoM";
  render::renderFrame(rmodel_, rdata_, f, cam);
  // Without an estimate in the log, no purple disc; the unloaded left plate draws no arrow.
  f.has_estimate = false;
  render::renderFrame(rmodel_, rdata_, f, cam);
  EXPECT_EQ(colouredPixels(rmodel_, rdata_.rgb, at(f.com_estimate), render::kColourComEstimate), 0);
  EXPECT_EQ(colouredPixels(rmodel_, rdata_.rgb, at(Eigen::Vector3d(0.25, 0.11, 0.2)), render::kColourWrench), 0);
}

// What a frame shows: the last sample of each channel at or before its tick; the estimate's CoM (its parameters
// through exoid's centroidal) against MuJoCo's subtree CoM of the same pose (the URDF's inertials are the MJCF's);
// the plate reading turned into the force on the foot at the CoP.
TEST_F(Render, FramesShowTheLastSampleOfEachChannelAndTheEstimateCom) {
  intake::RunLog log;
  const render::FrameState bent = pose(true);
  for (int64_t k = 0; k < 1000; k += 2) {  // truth on even ticks only
    GroundTruthSample g;
    g.tick = k;
    g.base_position = bent.base_position, g.base_orientation = bent.base_orientation;
    g.q = bent.q * (static_cast<double>(k) / 1000.0);
    g.v = g.a = g.tau_applied = Eigen::VectorXd::Zero(model_.njoints);
    g.com = Eigen::Vector3d(0, 0, static_cast<double>(k));  // the tick, to see which sample a frame took
    log.truth.push_back(g);
  }
  for (int64_t k = 0; k < 1000; k += 10) {
    ControllerStatusSample c;
    c.tick = k, c.com_ref = Eigen::Vector3d(1, 0, static_cast<double>(k));
    log.status.push_back(c);
    ForcePlateSample p;
    p.tick = k, p.plate = 0;
    p.force = Eigen::Vector3d(10, 0, -300);  // on the plate, plate frame (= world here)
    p.cop = Eigen::Vector3d(0.02, 0.01, 0.0), p.plate_position = Eigen::Vector3d(0.03, -0.11, -0.025);
    log.plates[0].push_back(p);
  }
  EstimatorOutputSample e;
  e.tick = 500, e.valid = true, e.params = model_.phi;
  log.estimates.push_back(e);
  std::vector<render::FrameState> frames;
  std::string err;
  ASSERT_TRUE(render::sampleRunFrames(model_, log, render::FrameTimes{30.0, 0.1, 0.9}, frames, &err)) << err;
  ASSERT_EQ(frames.size(), 25u);  // 0.1 s, 0.1333 s, ..., 0.9 s
  mjData* d = mj_makeData(rmodel_.sim.m);
  for (size_t i = 0; i < frames.size(); ++i) {
    const render::FrameState& f = frames[i];
    const int64_t tick = std::llround((0.1 + static_cast<double>(i) / 30.0) * 1000.0);
    EXPECT_EQ(f.tick, tick - tick % 2) << i;
    EXPECT_EQ(f.com_true.z(), static_cast<double>(tick - tick % 2)) << i;
    EXPECT_TRUE(f.has_status);
    EXPECT_EQ(f.com_ref.z(), static_cast<double>(tick - tick % 10)) << i;
    ASSERT_TRUE(f.loaded[0] && !f.loaded[1]) << i;
    EXPECT_TRUE(f.force[0].isApprox(Eigen::Vector3d(-10, 0, 300), 1e-12));
    EXPECT_TRUE(f.cop[0].isApprox(Eigen::Vector3d(0.05, -0.10, -0.025), 1e-12));
    EXPECT_EQ(f.has_estimate, f.tick >= 500) << i;
    if (!f.has_estimate) continue;
    for (int j = 0; j < rmodel_.sim.m->nq; ++j) d->qpos[j] = rmodel_.sim.qpos_init[static_cast<size_t>(j)];
    const int b = rmodel_.sim.base_qpos;
    for (int k = 0; k < 3; ++k) d->qpos[b + k] = f.base_position[k];
    d->qpos[b + 3] = f.base_orientation.w(), d->qpos[b + 4] = f.base_orientation.x();
    d->qpos[b + 5] = f.base_orientation.y(), d->qpos[b + 6] = f.base_orientation.z();
    for (int j = 0; j < model_.njoints; ++j) d->qpos[rmodel_.joint_qpos[static_cast<size_t>(j)]] = f.q[j];
    mj_kinematics(rmodel_.sim.m, d);
    mj_comPos(rmodel_.sim.m, d);
    const Eigen::Vector3d mujoco_com(d->subtree_com + 3 * rmodel_.sim.base_body);
    EXPECT_LT((f.com_estimate - mujoco_com).norm(), 1e-9) << i << ": " << f.com_estimate.transpose() << " vs "
                                                           << mujoco_com.transpose();
  }
  mj_deleteData(d);
}

// 600 ticks of truth at the standing pose, written with the LCM types.
std::string writeTruthLog(const Model& model, const std::string& path) {
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  exoid_lcm::ground_truth_t msg;
  for (int64_t k = 0; k < 600; ++k) {
    GroundTruthSample g;
    g.tick = k, g.utime = 1000 * k;
    g.base_position = Eigen::Vector3d(0, 0, 1.04);
    g.q = g.v = g.a = g.tau_applied = Eigen::VectorXd::Zero(model.njoints);
    g.foot_force = {Eigen::Vector3d(0, 0, 300), Eigen::Vector3d(0, 0, 300)};
    g.foot_moment = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    g.com = Eigen::Vector3d(0.03, 0, 1.0);
    toLcm(g, model.joint_names, msg);
    std::vector<uint8_t> buf(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(buf.data(), 0, static_cast<int>(buf.size()));
    lcm_eventlog_event_t e{};
    e.timestamp = g.utime;
    e.channellen = static_cast<int32_t>(std::strlen(channels::kTruth));
    e.channel = const_cast<char*>(channels::kTruth);
    e.datalen = static_cast<int32_t>(buf.size());
    e.data = buf.data();
    lcm_eventlog_write_event(log, &e);
  }
  lcm_eventlog_destroy(log);
  return path;
}

TEST_F(Render, DamagedLogIsRefusedUnlessAllowPartialAndFramesFollowTheRun) {
  const test::TempDir dir("render_cli");
  const std::string good = writeTruthLog(model_, dir.file("run.lcmlog")), cut = dir.file("cut.lcmlog");
  const auto size = std::filesystem::file_size(good);
  std::filesystem::copy_file(good, cut);
  std::filesystem::resize_file(cut, size / 2 + 7);  // inside an event
  const std::string cmd = test::exoidBinary() + " render --quiet --format none --width 160 --height 120 --fps 10 --log ";
  auto r = test::runCommand(cmd + cut + " --out " + dir.file("refused") + " --keyframes", dir.path);
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("readable part ends at byte"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("refused")));
  r = test::runCommand(cmd + cut + " --out " + dir.file("partial") + " --frames --allow-partial", dir.path);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const long partial = std::distance(std::filesystem::directory_iterator(dir.file("partial/front")), {});
  EXPECT_GE(partial, 1);
  EXPECT_LT(partial, 6);  // only the readable part: ticks 0 .. ~300
  r = test::runCommand(cmd + good + " --out " + dir.file("all") + " --frames --keyframes", dir.path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.file("all/front")), {}), 6);  // t = 0, 0.1, ..., 0.5
  EXPECT_TRUE(std::filesystem::exists(dir.file("all/keyframes.png")));
}

// The reports' strips (exoid diagnose, exoid study) come from writeRunKeyframes: the same picture, byte for byte,
// as `exoid render --keyframes` at its defaults (640x480, 30 fps, front view); a damaged log is drawn from its
// readable part with the damage named, a log without the truth channel is not drawn and says why.
TEST_F(Render, RunKeyframesAreTheKeyframesOfExoidRender) {
  const test::TempDir dir("render_keyframes");
  const std::string good = writeTruthLog(model_, dir.file("run.lcmlog")), cut = dir.file("cut.lcmlog");
  std::filesystem::copy_file(good, cut);
  std::filesystem::resize_file(cut, std::filesystem::file_size(good) / 2 + 7);
  std::string note, err;
  ASSERT_TRUE(render::writeRunKeyframes(good, model_, config("exo.xml"), dir.file("strip.png"), &note, &err)) << err;
  EXPECT_EQ(note, "");
  const auto r = test::runCommand(test::exoidBinary() + " render --quiet --format none --keyframes --log " + good +
                                      " --out " + dir.file("cli"), dir.path);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto bytes = [](const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  const std::string strip = bytes(dir.file("strip.png"));
  ASSERT_GT(strip.size(), 24u);
  EXPECT_EQ(strip, bytes(dir.file("cli/keyframes.png")));
  auto be32 = [&](size_t at) {  // the PNG's IHDR: width and height, big-endian, at bytes 16 and 20
    return (static_cast<uint32_t>(static_cast<unsigned char>(strip[at])) << 24) |
           (static_cast<uint32_t>(static_cast<unsigned char>(strip[at + 1])) << 16) |
           (static_cast<uint32_t>(static_cast<unsigned char>(strip[at + 2])) << 8) | static_cast<unsigned char>(strip[at + 3]);
  };
  EXPECT_EQ(be32(16), 3u * 640u);
  EXPECT_EQ(be32(20), 480u);
  ASSERT_TRUE(render::writeRunKeyframes(cut, model_, config("exo.xml"), dir.file("cut.png"), &note, &err)) << err;
  EXPECT_NE(note.find("readable part ends at byte"), std::string::npos) << note;
  {  // a log with another channel only: refused with the reason
    lcm_eventlog_t* log = lcm_eventlog_create(dir.file("other.lcmlog").c_str(), "w");
    char data[4] = {0, 0, 0, 0};
    lcm_eventlog_event_t e{};
    e.channellen = 5, e.channel = const_cast<char*>("OTHER"), e.datalen = 4, e.data = data;
    lcm_eventlog_write_event(log, &e);
    lcm_eventlog_destroy(log);
  }
  EXPECT_FALSE(render::writeRunKeyframes(dir.file("other.lcmlog"), model_, config("exo.xml"), dir.file("other.png"), &note, &err));
  EXPECT_FALSE(err.empty());
  EXPECT_FALSE(std::filesystem::exists(dir.file("other.png")));
}

TEST(RenderCli, HelpDocumentsTheDamageRuleAndBadOptionsAreOneLine) {
  const test::TempDir dir("render_help");
  auto r = test::runCommand(test::exoidBinary() + " render --help", dir.path);
  EXPECT_EQ(r.exit_code, 0);
  for (const char* needle : {"--allow-partial", "3 the log is damaged", "--views", "--from", "--to", "--fps", "--scenario"})
    EXPECT_NE(r.out.find(needle), std::string::npos) << needle;
  r = test::runCommand(test::exoidBinary() + " render --log x --out y --width 641", dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "exoid render: error: --width and --height must be even (H.264's yuv420p)\n");
  r = test::runCommand(test::exoidBinary() + " render --log x --out y --views front,top", dir.path);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("unknown view 'top'"), std::string::npos) << r.err;
}

TEST(RenderCli, LiveViewWithoutADisplayIsOneLineAndTheRunGoesOn) {
  const test::TempDir dir("render_view");
  const auto r = test::runCommand(std::string("env -u DISPLAY -u WAYLAND_DISPLAY ") + EXO_SIM_BIN +
                                      " --view --duration 0.01 --lcm-url memq:// --start-timeout-s 0.01 --quiet",
                                  dir.path);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "exo_sim: --view: no display (DISPLAY is not set): running without the live view\n");
  EXPECT_NE(r.out.find("completed, ticks 10 of 10"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace exoid
