// exoid render: a logged run as pictures (thin main: options -> sampleRunFrames + renderRun -> one summary line).
#include <unistd.h>

#include <cstdio>
#include <sstream>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/render/render_run.hpp"
#include "exoid/sim/config.hpp"

namespace exoid::cli {

namespace cmd_render {  // this file's own names: the exoid binary is a unity build
int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid render: error: %s\n", msg.c_str());
  return 2;
}

// "front,side" -> cameras; false with *err on an unknown name.
bool parseViews(const std::string& list, std::vector<render::ViewCamera>& views, std::string* err) {
  std::stringstream ss(list);
  std::string name;
  while (std::getline(ss, name, ',')) {
    render::ViewCamera v;
    if (!render::viewCamera(name, v)) return *err = "--views: unknown view '" + name + "' (front, side, back, iso)", false;
    for (const render::ViewCamera& w : views)
      if (w.name == name) return *err = "--views: '" + name + "' named twice (each view writes its own files)", false;
    views.push_back(v);
  }
  if (views.empty()) return *err = "--views: no view named", false;
  return true;
}

// A bar on a terminal; elsewhere (a log file) one line per 10 %.
render::RenderProgress progressBar(bool quiet) {
  if (quiet) return nullptr;
  const bool tty = isatty(STDERR_FILENO);
  return [tty, last = -1L](long done, long total) mutable {
    const long pct = 100 * done / total;
    if (tty) {
      const int bar = static_cast<int>(40 * done / total);
      std::fprintf(stderr, "\r[%-40.*s] %3ld%% %ld/%ld frames", bar, "########################################", pct, done, total);
      if (done == total) std::fputc('\n', stderr);
    } else if (pct / 10 != last / 10 || done == total) {
      std::fprintf(stderr, "exoid render: %ld/%ld frames (%ld%%)\n", done, total, pct);
    }
    last = pct;
  };
}
}  // namespace cmd_render

int cmdRender(int argc, char** argv) {
  using namespace cmd_render;
  CLI::App app{
      "Renders a logged run with MuJoCo's renderer, headless (EGL; no display needed): the robot in the pose of the\n"
      "truth channel (EXO_TRUTH), the true CoM (red sphere), the controller's reference (green cross) and its own CoM\n"
      "(yellow disc), the online estimate's CoM (purple disc), each with its floor projection, the plate forces on the\n"
      "feet as cyan arrows at the CoPs (1 mm per N), payloads of --scenario as pink spheres. Writes per view\n"
      "DIR/<view>.mp4 (and/or .gif, PNG frames in DIR/<view>/), real time at --fps. A damaged log is refused\n"
      "unless --allow-partial.",
      "exoid render"};
  common::configureCli(app);
  std::string log_path, out_dir, views = "front", format = "mp4", scenario_path;
  std::string mjcf = std::string(EXOID_CONFIG_DIR) + "/exo.xml", urdf = std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  render::FrameTimes times;
  render::RenderRunOptions opt;
  int width = 640, height = 480;
  bool allow_partial = false, quiet = false;
  app.add_option("--log", log_path, "lcm-logger file of a run (exoid experiment writes DIR/run.lcmlog)")->required()->type_name("FILE");
  app.add_option("--out", out_dir, "folder for the pictures (created)")->required()->type_name("DIR");
  app.add_option("--from", times.from_s, "start of the window, s of the run")->transform(common::strictNumber(0, 1e7))->type_name("S");
  app.add_option("--to", times.to_s, "end of the window, s of the run (default: the end)")
      ->transform(common::strictNumber(0, 1e7))->type_name("S")->default_str("end");
  app.add_option("--fps", times.fps, "frames per second of the run (real time)")->transform(common::strictNumber(0.1, 1000))->type_name("HZ");
  app.add_option("--width", width, "frame width, pixels (even)")->transform(common::strictInteger(64, 4096))->type_name("PX");
  app.add_option("--height", height, "frame height, pixels (even)")->transform(common::strictInteger(64, 4096))->type_name("PX");
  app.add_option("--views", views, "cameras, comma-separated: front, side, back, iso")->type_name("LIST");
  app.add_option("--format", format, "video: mp4, gif, both or none")->check(CLI::IsMember({"mp4", "gif", "both", "none"}))->type_name("F");
  app.add_option("--gif-width", opt.gif_width, "GIF scaled to this width (0: the frames')")->transform(common::strictInteger(0, 4096))->type_name("PX");
  app.add_flag("--frames", opt.png, "also every frame as a PNG: DIR/<view>/frame_00000.png, ...");
  app.add_flag("--keyframes", opt.keyframes, "also DIR/keyframes.png: start, largest CoM excursion and end (first view)");
  app.add_option("--scenario", scenario_path, "the run's scenario: its payloads are drawn")->type_name("YAML");
  app.add_option("--model", mjcf, "the scene (MJCF of the robot and plates)")->type_name("MJCF");
  app.add_option("--urdf", urdf, "robot model naming the joints")->type_name("URDF");
  app.add_flag("--allow-partial", allow_partial, "render what is readable from a damaged log (the damage is still reported)");
  app.add_flag("--quiet", quiet, "no progress bar");
  app.footer("speed: one frame of 640x480 takes ~15-30 ms on one core (llvmpipe); the summary line prints the rate.\n\n"
             "exit codes: 0 success (with --allow-partial also from a damaged log), 2 bad input or failure (unreadable\n"
             "            log, no truth channel, ffmpeg missing), 3 the log is damaged (nothing written; see --allow-partial).");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  if (width % 2 || height % 2) return fail("--width and --height must be even (H.264's yuv420p)");
  opt.mp4 = format == "mp4" || format == "both", opt.gif = format == "gif" || format == "both";
  if (!opt.mp4 && !opt.gif && !opt.png && !opt.keyframes) return fail("nothing to write: --format none without --frames or --keyframes");
  opt.out_dir = out_dir, opt.fps = times.fps;
  std::string err;
  if (!parseViews(views, opt.views, &err)) return fail(err);
  Model model;
  if (!buildModelFromUrdfFile(urdf, true, model, &err)) return fail(err);
  sim::Scenario scenario;
  if (!scenario_path.empty() && !sim::loadScenario(scenario_path, &scenario, &err)) return fail(err);
  intake::RunLog log;
  if (!intake::readRunLog(log_path, model.joint_names, log, &err)) return fail(err);
  if (!log.intact()) {
    std::fprintf(stderr, "exoid render: %s: %s: %s\n", allow_partial ? "warning" : "error", log_path.c_str(),
                 log.damageReport().c_str());
    if (!allow_partial) return 3;
  }
  std::vector<render::FrameState> frames;
  if (!render::sampleRunFrames(model, log, times, frames, &err)) return fail(log_path + ": " + err);
  render::RenderModel rmodel;
  render::RenderData rdata;
  render::RenderRunStats stats;
  if (!render::loadRenderModel(mjcf, model, scenario, width, height, rmodel, &err) ||
      !render::makeRenderData(rmodel, rdata, &err) || !render::renderRun(rmodel, rdata, frames, opt, stats, progressBar(quiet), &err))
    return fail(err);
  if (stats.frames > 0)
    std::printf("exoid render: %ld frames x %zu views (%.2f s of the run, %.3g fps) -> %s in %.1f s: %.1f images/s, %.2fx real time\n",
                stats.frames, opt.views.size(), stats.run_s, times.fps, out_dir.c_str(), stats.wall_s, stats.imagesPerSecond(),
                stats.realtimeFactor());
  if (opt.keyframes)
    std::printf("exoid render: keyframes %s/keyframes.png at t = %.2f (start), %.2f (largest CoM excursion), %.2f s (end)\n",
                out_dir.c_str(), stats.keyframe_t[0], stats.keyframe_t[1], stats.keyframe_t[2]);
  return 0;
}

}  // namespace exoid::cli
