#pragma once
// The sensors pipeline's base signals as `exoid identify`, `exoid study` and `exoid diagnose` take them (one set of
// options, one text; docs/identification.md "Input pipelines" and "The soles' tilt from the plates").
#include <CLI/CLI.hpp>

#include "exoid/tools/identify_input.hpp"

namespace exoid::cli {

/// --base-orientation plates|fused|imu, --base-rate legs|gyro, --base-acceleration legs|accelerometer,
/// --orientation-cutoff HZ into `b`; its values are the defaults --help shows (identify and study: tools::BaseSignals's,
/// diagnose: its own).
void addBaseSignalOptions(CLI::App& app, tools::BaseSignals& b);

}  // namespace exoid::cli
