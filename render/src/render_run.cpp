#include "exoid/render/render_run.hpp"

#include <chrono>
#include <filesystem>
#include <memory>
#include <system_error>

#include "exoid/render/video_writer.hpp"

namespace exoid::render {

namespace {
bool fail(std::string* err, const std::string& msg) {
  if (err) *err = msg;
  return false;
}

// One ffmpeg process per view with the outputs asked for.
bool openWriters(const RenderModel& model, const RenderRunOptions& o, std::vector<std::unique_ptr<VideoWriter>>& writers,
                 std::string* err) {
  for (const ViewCamera& v : o.views) {
    VideoOutputs out;
    const std::string base = o.out_dir + "/" + v.name;
    if (o.mp4) out.mp4 = base + ".mp4";
    if (o.gif) out.gif = base + ".gif", out.gif_width = o.gif_width;
    if (o.png) {
      std::error_code ec;
      std::filesystem::create_directories(base, ec);
      if (ec) return fail(err, base + ": " + ec.message());
      out.png_pattern = base + "/frame_%05d.png";
    }
    writers.push_back(std::make_unique<VideoWriter>());
    if (!writers.back()->open(out, model.width, model.height, o.fps, err)) return false;
  }
  return true;
}
}  // namespace

bool renderRun(const RenderModel& model, RenderData& data, const std::vector<FrameState>& frames,
               const RenderRunOptions& o, RenderRunStats& stats, const RenderProgress& progress, std::string* err) {
  if (frames.empty() || o.views.empty()) return fail(err, "nothing to render (no frame or no view)");
  std::error_code ec;
  std::filesystem::create_directories(o.out_dir, ec);
  if (ec) return fail(err, o.out_dir + ": " + ec.message());
  const auto t0 = std::chrono::steady_clock::now();
  stats = RenderRunStats();
  if (o.mp4 || o.gif || o.png) {
    std::vector<std::unique_ptr<VideoWriter>> writers;
    if (!openWriters(model, o, writers, err)) return false;
    const long n = static_cast<long>(frames.size());
    for (long k = 0; k < n; ++k) {
      for (size_t v = 0; v < o.views.size(); ++v) {
        renderFrame(model, data, frames[static_cast<size_t>(k)], o.views[v]);
        if (!writers[v]->write(data.rgb.data())) break;  // ffmpeg stopped: close() says why
      }
      if (progress) progress(k + 1, n);
    }
    for (auto& w : writers)
      if (!w->close(err)) return false;
    stats.frames = n;
    stats.images = n * static_cast<long>(o.views.size());
  }
  if (o.keyframes) {
    if (!writeKeyframeStrip(model, data, frames, o.views.front(), o.out_dir + "/keyframes.png", err)) return false;
    stats.images += 3;
    const size_t picks[3] = {0, largestComExcursion(frames), frames.size() - 1};
    for (int i = 0; i < 3; ++i) stats.keyframe_t[i] = frames[picks[i]].t;
  }
  stats.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stats.run_s = frames.back().t - frames.front().t + 1.0 / o.fps;
  return true;
}

bool writeKeyframeStrip(const RenderModel& model, RenderData& data, const std::vector<FrameState>& frames,
                        const ViewCamera& camera, const std::string& png_path, std::string* err) {
  if (frames.empty()) return fail(err, "no frame for the keyframe strip");
  const size_t picks[3] = {0, largestComExcursion(frames), frames.size() - 1};
  const size_t w = static_cast<size_t>(model.width) * 3, row = w * 3;  // bytes per strip row: 3 images
  std::vector<unsigned char> strip(row * static_cast<size_t>(model.height));
  for (size_t i = 0; i < 3; ++i) {
    renderFrame(model, data, frames[picks[i]], camera);
    for (int r = 0; r < model.height; ++r)
      std::copy_n(data.rgb.begin() + static_cast<long>(static_cast<size_t>(r) * w), w,
                  strip.begin() + static_cast<long>(static_cast<size_t>(r) * row + i * w));
  }
  VideoWriter writer;
  VideoOutputs out;
  out.png_pattern = png_path;
  if (!writer.open(out, model.width * 3, model.height, 1.0, err)) return false;
  writer.write(strip.data());
  return writer.close(err);
}

}  // namespace exoid::render
