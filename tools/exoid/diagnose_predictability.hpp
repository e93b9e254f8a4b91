#pragma once
// `exoid diagnose`'s outputs of its last stage (residual predictability, docs/diagnose.md): predictability.csv,
// predictability_series.csv, plot_predictability.py and its predictability.png, the summary.json entry, the
// report.md section and the console lines.
#include <nlohmann/json.hpp>

#include <string>

#include "exoid/estimator/residual_predictability.hpp"

namespace exoid::cli {

/// Writes the files into out_dir, adds "predictability" to js, returns the report section in *report and the
/// console lines in *console. plot: run the script with python. False with *error when a file cannot be written.
bool writePredictability(const std::string& out_dir, const Model& model, const estimator::PredictabilityResult& result,
                         const estimator::PredictabilityOptions& options, bool plot, const std::string& python,
                         nlohmann::json& js, std::string* report, std::string* console, std::string* error);

}  // namespace exoid::cli
