#pragma once
// Figures of merit of a closed-loop run, computed from its log (truth channel for what only the simulator
// knows, controller status for what the controller reports).
#include <string>

#include "exoid/model/model.hpp"
#include "exoid/tools/run_log.hpp"

namespace exoid::tools {

struct ExperimentSummary {
  int moves_planned = 0;
  int moves_done = 0;
  bool fell = false;               ///< the true base height dropped > 0.25 m below its start
  double com_rmse_m = 0.0;         ///< model CoM (the URDF model at the exact state) vs the CoM reference
  double com_max_error_m = 0.0;
  double true_com_rmse_m = 0.0;    ///< the simulated robot's CoM (undeclared payloads included) vs the reference
  double true_com_max_error_m = 0.0;
  double max_foot_slip_m = 0.0;    ///< largest horizontal displacement of either sole centre from its start
  double qp_solve_us_p50 = 0.0, qp_solve_us_p99 = 0.0;
  double tick_us_p50 = 0.0, tick_us_p99 = 0.0;
  long fallbacks = 0;              ///< controller ticks on a fallback command
  long controller_rejected = 0;    ///< input messages the controller rejected
  double realtime_factor = 0.0;    ///< simulated time / wall time
  double sim_seconds = 0.0;
  long ticks = 0;                  ///< ticks in the truth channel
  long missing_ticks = 0;          ///< ticks absent from any sim channel (lost messages) within the run
  long log_rejected = 0;           ///< logged events that failed decoding or validation
  double eom_residual_max_rel = -1.0;  ///< W phi_model - y, max relative (-1: not computed)
};

/// moves_planned: the number of CoM moves the controller was asked for; wall_seconds: how long the sim ran.
bool summarizeExperiment(const Model& model, const RunLog& log, int moves_planned, double wall_seconds,
                         ExperimentSummary& out, std::string* error);

std::string summaryJson(const ExperimentSummary& s);
/// Readable two-column table (also valid Markdown).
std::string summaryTable(const ExperimentSummary& s);

}  // namespace exoid::tools
