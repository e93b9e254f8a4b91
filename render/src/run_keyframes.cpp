#include "exoid/render/run_keyframes.hpp"

#include <vector>

#include "exoid/intake/run_log.hpp"
#include "exoid/render/render_run.hpp"
#include "exoid/render/run_frames.hpp"
#include "exoid/render/scene.hpp"
#include "exoid/sim/config.hpp"

namespace exoid::render {

bool writeRunKeyframes(const std::string& log_path, const Model& model, const std::string& mjcf_path,
                       const std::string& png_path, std::string* note, std::string* err) {
  intake::RunLog log;
  if (!intake::readRunLog(log_path, model.joint_names, log, err)) return false;
  if (note) *note = log.intact() ? std::string() : "damaged log, its readable part drawn: " + log.damageReport();
  std::vector<FrameState> frames;
  if (!sampleRunFrames(model, log, FrameTimes{}, frames, err)) return *err = log_path + ": " + *err, false;
  ViewCamera front;
  viewCamera("front", front);
  RenderModel rmodel;
  RenderData rdata;
  return loadRenderModel(mjcf_path, model, sim::Scenario{}, 640, 480, rmodel, err) && makeRenderData(rmodel, rdata, err) &&
         writeKeyframeStrip(rmodel, rdata, frames, front, png_path, err);
}

}  // namespace exoid::render
