#pragma once
// `exoid diagnose`'s outputs of the base rows' stage (an unmeasured body on the base, docs/diagnose.md):
// unmeasured_body.csv, unmeasured_body_series.csv, plot_unmeasured_body.py and its unmeasured_body.png, the
// summary.json entry, the report.md section and the console lines.
#include <nlohmann/json.hpp>

#include <string>

#include "exoid/estimator/unmeasured_body.hpp"

namespace exoid::cli {

/// Writes the files into out_dir, adds "unmeasured_body" to js, returns the report section in *report and the
/// console lines in *console. plot: run the script with python. False with *error when a file cannot be written.
bool writeUnmeasuredBody(const std::string& out_dir, const estimator::UnmeasuredBodyResult& result,
                         const estimator::UnmeasuredBodyOptions& options, bool plot, const std::string& python,
                         nlohmann::json& js, std::string* report, std::string* console, std::string* error);

}  // namespace exoid::cli
