#pragma once
// The sensors pipeline's base signals as `exoid identify` and `exoid study` take them (one set of options, one text;
// docs/identification.md "Input pipelines" and "The soles' tilt from the plates").
#include <CLI/CLI.hpp>
#include <string>

namespace exoid::cli {

/// --base-orientation plates|fused|imu, --base-rate legs|gyro, --base-acceleration legs|accelerometer,
/// --orientation-cutoff HZ into the given fields (their defaults stay as the caller set them).
void addBaseSignalOptions(CLI::App& app, std::string& orientation, std::string& base_rate, std::string& base_acceleration,
                          double& orientation_cutoff_hz);

}  // namespace exoid::cli
