#include "exoid/render/run_keyframes.hpp"

#include <sstream>
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

std::string runKeyframesSection(const std::vector<ReportRun>& runs, const Model* model, const std::string& no_model_why,
                                const std::string& mjcf_path, const std::string& out_dir) {
  std::ostringstream md;
  md << "## The runs\n\nEach run as keyframes: start, largest CoM excursion, end (`exoid render --keyframes`).\n\n";
  for (const ReportRun& r : runs) {
    std::string note, err = no_model_why;
    md << "- " << r.role << " `" << r.log_path << "`";
    if (model && writeRunKeyframes(r.log_path, *model, mjcf_path, out_dir + "/" + r.png, &note, &err))
      md << (note.empty() ? "" : " (" + note + ")") << ":\n\n  ![" << r.role << " run](" << r.png << ")\n\n";
    else
      md << ": not drawn (" << err << ")\n\n";
  }
  return md.str();
}

}  // namespace exoid::render
