#pragma once
// `exoid diagnose`'s writers (docs/diagnose.md): report.md, summary.json, rmse.csv, candidates.csv, signals.csv,
// residual_<segment>.csv, the sidecar effects.yaml next to a copy of the URDF (and the declared model with its payloads),
// the plots and the console summary, from what the command was asked and what the diagnosis found.
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/tools/identify_input.hpp"

namespace exoid::cli {

/// What `exoid diagnose` was asked: the files and choices the outputs name.
struct DiagnoseInputs {
  std::string model_path, out_dir, declared = "rigid", declared_model_path, python = "python3";
  std::vector<std::string> train_files, calib_files, val_files, val_calib_files;
  bool no_plots = false;
  /// The scene of the runs' keyframe strips in report.md (LCM-log inputs only; none with no_plots).
  std::string scene_mjcf = std::string(EXOID_CONFIG_DIR) + "/exo.xml";
};

/// Opens out/name for writing; false with *error = "cannot write '...'" when it cannot.
bool openOut(const std::filesystem::path& out, const std::string& name, std::ofstream& f, std::string* error);

/// The one way `exoid diagnose` plots: the script `name` is written into out_dir next to the CSVs it reads and, when
/// `run`, run as `python 'out_dir/name' args` (a failure is a warning on stderr: the CSVs stay). *plotted: it ran and
/// succeeded. False with *error when the script cannot be written.
bool writePlotScript(const std::string& out_dir, const std::string& name, const char* script, bool run,
                     const std::string& python, const std::string& args, bool* plotted, std::string* error);

/// The augmented model's sidecar content: the URDF's file name, the shape constants, the accepted effects.
estimator::EffectSet effectSetOf(const std::string& model_path, const estimator::DiagnoseOptions& opt,
                                 const estimator::DiagnosisResult& res);

/// Every output of `exoid diagnose` into in.out_dir (created), the inputs' skips and the summary on stdout. stats:
/// per file of train, calibration, validation, validation-calibration (in that order). False with *error when a file
/// cannot be written.
bool writeDiagnosis(const Model& model, const Model& declared_model, const estimator::DiagnoseOptions& opt,
                    const DiagnoseInputs& in, const std::vector<intake::InputStats>& stats,
                    const estimator::DiagnosisResult& res, const estimator::OnlineComparison& online, std::string* error);

}  // namespace exoid::cli
