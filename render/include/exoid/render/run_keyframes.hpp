#pragma once
// The keyframe strip of a logged run in one call: what the reports show of the runs they used (`exoid diagnose`,
// `exoid study`), the same picture as `exoid render --keyframes` (start, largest CoM excursion, end; front view).
#include <string>
#include <vector>

#include "exoid/model/model.hpp"

namespace exoid::render {

/// Reads `log_path` through the intake (a damaged log: its readable part, the damage in *note), samples it at
/// 30 frames per second, and writes the strip of 3 x (640 x 480) pixels to `png_path`. The scene is `mjcf_path`
/// (the sim's MJCF, no scenario: payloads are not drawn); `model` names the joints (the URDF of the run).
/// False with *err: unreadable log, no truth channel, joints the MJCF lacks, no EGL, ffmpeg missing.
bool writeRunKeyframes(const std::string& log_path, const Model& model, const std::string& mjcf_path,
                       const std::string& png_path, std::string* note, std::string* err);

/// A run a report shows: its role ("training"), its log, the strip's file name in the report's folder.
struct ReportRun {
  std::string role, log_path, png;
};

/// The reports' "## The runs" section (markdown): each run's strip written into out_dir (writeRunKeyframes) and
/// linked, with a damaged log's note, or one line saying why it is not drawn. model == nullptr: none is drawn,
/// each says `no_model_why`.
std::string runKeyframesSection(const std::vector<ReportRun>& runs, const Model* model, const std::string& no_model_why,
                                const std::string& mjcf_path, const std::string& out_dir);

}  // namespace exoid::render
