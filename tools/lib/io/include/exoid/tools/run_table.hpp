#pragma once
// A run as one row per tick (the `exoid export` schema, docs/data-formats.md), and the equation-of-motion
// residual of a run. Both align every channel by tick; a tick missing any needed message is skipped and
// counted, never filled in.
#include <string>
#include <vector>

#include "exoid/estimator/dataset.hpp"
#include "exoid/model/model.hpp"
#include "exoid/intake/run_log.hpp"

namespace exoid::tools {

struct ExportOptions {
  bool truth = false;        ///< ground-truth channel instead of the sensors
  double filter_hz = 0.0;    ///< sensors only: > 0 adds v_/a_ and base_dw* by zero-phase Butterworth + differences
};

struct RunTable {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  long skipped_ticks = 0;    ///< ticks with a missing message on a needed channel
  long repeated_messages = 0;     ///< a tick's message again on its channel (the first kept; tick_assembly.hpp)
  long out_of_order_messages = 0;  ///< messages for a tick already passed
};

/// Builds the table. Fails with *error if the log has no usable tick or the options are invalid.
bool buildRunTable(const Model& model, const intake::RunLog& log, const ExportOptions& options, RunTable& table,
                   std::string* error);

// Sample alignment, state from samples and plate wrenches live in the estimator library (dataset.hpp).
using estimator::footWrenchFromPlate;
using estimator::stateFromTruth;

struct EomResidual {
  long ticks = 0;
  double max_relative = 0.0;     ///< max over ticks and rows of |W phi - y|, over the run's max |y| (a per-tick
                                 ///< ratio is meaningless at touch-down, where y is ~0 in free fall)
  double rms_absolute = 0.0;     ///< RMS of W phi - y over all rows and ticks (N, N m)
  std::vector<double> rms_per_row;  ///< [nv]
};

/// Residual of K(q, v, dv) phi = y over a run, with q, v, dv and the base pose from the ground-truth
/// channel (the simulator's own accelerations), joint torques from the joint torque sensors (EXO_STATE,
/// unactuated joints 0) and external wrenches from the force plates. phi: parameters to test (e.g. the
/// model's). Needs the model's "right_foot" and "left_foot" bodies.
bool eomResidual(const Model& model, const Eigen::VectorXd& phi, const intake::RunLog& log, EomResidual& out,
                 std::string* error);

}  // namespace exoid::tools
