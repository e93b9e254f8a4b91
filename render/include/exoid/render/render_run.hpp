#pragma once
// The whole render of a run (what `exoid render` calls): every frame from every view, through ffmpeg, into
//   DIR/<view>.mp4, DIR/<view>.gif, DIR/<view>/frame_NNNNN.png   (the ones asked for)
//   DIR/keyframes.png   (optional: start, largest CoM excursion, end of the window, first view, side by side)
#include <functional>
#include <string>
#include <vector>

#include "exoid/render/run_frames.hpp"
#include "exoid/render/scene.hpp"

namespace exoid::render {

struct RenderRunOptions {
  std::string out_dir;
  std::vector<ViewCamera> views;  ///< at least one
  double fps = 30.0;              ///< the frames' rate (real time: one frame per 1 / fps s of the run)
  bool mp4 = true, gif = false, png = false, keyframes = false;
  int gif_width = 0;              ///< 0: the frames' width
};

struct RenderRunStats {
  long frames = 0;      ///< per view
  long images = 0;      ///< frames x views (+ 3 for the keyframes)
  double wall_s = 0.0;  ///< rendering and encoding
  double run_s = 0.0;   ///< the window's length in the run
  double keyframe_t[3] = {0, 0, 0};  ///< s: the keyframes' times (start, largest CoM excursion, end)
  /// Images per wall-clock second, and the run's seconds per wall-clock second (>= 1: faster than real time).
  double imagesPerSecond() const { return wall_s > 0 ? static_cast<double>(images) / wall_s : 0.0; }
  double realtimeFactor() const { return wall_s > 0 ? run_s / wall_s : 0.0; }
};

/// Called after each frame (all views): frames done, frames in all.
using RenderProgress = std::function<void(long done, long total)>;

/// Renders `frames` (sampleRunFrames) into the outputs named above. False with *err (folder not writable,
/// ffmpeg missing or failed); files already written stay, the message names what failed.
bool renderRun(const RenderModel& model, RenderData& data, const std::vector<FrameState>& frames,
               const RenderRunOptions& options, RenderRunStats& stats, const RenderProgress& progress, std::string* err);

/// Writes frames[start], frames[largestComExcursion], frames.back() from `camera` side by side into one PNG.
bool writeKeyframeStrip(const RenderModel& model, RenderData& data, const std::vector<FrameState>& frames,
                        const ViewCamera& camera, const std::string& png_path, std::string* err);

}  // namespace exoid::render
