#pragma once
// `exoid identify --hold`'s report of the added bodies (a wearer's segments, a payload; docs/wearer.md "Identify
// the wearer") and the system-CoM check against the truth channel: stdout lines, wearer.csv, wearer.png (its plot
// script) and summary.json's entries.
#include <nlohmann/json.hpp>
#include <string>

#include "exoid/tools/identify_run.hpp"

namespace exoid::cli {

/// The added bodies per carrying link and the system CoM errors, on stdout.
void printHoldReport(const tools::IdentifyRun& run);

/// summary.json's "added_bodies" (per carrying link: segments, excited, prior / identified / truth mass and CoM)
/// and "system_com" (RMSE of each model's CoM against the truth channel); null entries when not computed.
void holdJson(const tools::IdentifyRun& run, nlohmann::json& j);

/// out_dir/wearer.csv (one row per carrying link) and plot_wearer.py, run with `python` unless !plot
/// (wearer.png). False with *error when a file cannot be written.
bool writeHoldOutputs(const tools::IdentifyRun& run, const std::string& out_dir, bool plot, const std::string& python,
                      std::string* error);

}  // namespace exoid::cli
