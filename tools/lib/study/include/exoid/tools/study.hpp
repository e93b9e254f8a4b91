#pragma once
// `exoid study`: the thesis's comparison protocol (chapter 3, section IV; chapter 4, Table 4.1) on exoid's
// own runs, in one call: a training run (noise), an ideal validation run and optionally a held-out test run
// (each recorded with a different CoM move seed); for every input pipeline and filter cutoff one streamed
// training factor; for every prior range 20 random priors; per prior the methods Ref (the prior), OLS,
// WLS-R, WLS-C, WLS-RC with the rank chosen on the validation data (thesis), WLS-RC with the rank chosen from
// the training data alone (jackknife, cv, cv-1se, gcv; each scored), and WLS-RC-PC (physically consistent, at WLS-RC's
// rank); every estimate scored with the thesis's metrics (estimator/metrics.hpp) on the validation run (and
// the test run, which also gets chapter 4's realistic torque prediction, eq. 4.1). Writes results.csv (one row per estimate), table_c1.{csv,md} (means over the priors, the
// thesis's Table C.1), table2.{csv,md} (best over the cutoffs per metric, the thesis's Table II with its
// numbers beside), singular_values.csv and link_error.csv (Fig. 6); scripts/plot_study.py draws them.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "exoid/tools/identify_input.hpp"

namespace exoid::tools {

struct PriorRange {
  std::string name;        ///< "12.5%", "25%", "abs0.125"
  double value = 0.25;     ///< relative fraction, or absolute offset (parameter units)
  bool absolute = false;   ///< chapter 4 / Table D.1: phi_true + U(-value, value)
};

struct StudyOptions {
  std::string model_path;      ///< URDF (floating base)
  std::string train;           ///< LCM log of a noisy run (e.g. nominal.yaml)
  std::string validation;      ///< LCM log of an ideal run (ideal.yaml), another move seed
  std::string test;            ///< optional held-out LCM log, another move seed ("" = none)
  std::string thesis_table;    ///< CSV of the thesis's Table II (data/thesis/table2.csv); "" = none
  std::string out_dir;
  int priors = 20;
  uint64_t seed = 1;
  std::vector<double> cutoffs{0.0, 10.0, 15.0, 30.0, 50.0, 70.0, 100.0};  ///< Hz; 0 = no filter (the thesis's
                               ///< none/30/50/70/100 plus 10 and 15, where the sensors pipeline does best)
  int threads = 2;             ///< workers over the (pipeline, cutoff) jobs
  std::vector<std::string> pipelines{"thesis", "sensors"};     ///< thesis protocol / sensors only
  std::vector<PriorRange> ranges{{"12.5%", 0.125, false}, {"25%", 0.25, false}, {"abs0.125", 0.125, true}};
  bool parallel_filter = false;  ///< sensors pipeline: parallel filtering (W and y) instead of filtering the inputs
  BaseSignals base_signals;  ///< sensors pipeline: where the base's orientation, rate and acceleration come from
  int stride = 10;             ///< validation/test metric samples: every stride-th tick (thesis figures: 0.02 s)
  int pc_iterations = 100;     ///< Newton iterations of WLS-RC-PC per estimate
  double pc_nullspace = 3e-2;  ///< WLS-RC-PC pull toward the prior in the unused directions, relative to s_z^2
  double realistic_cutoff_hz = 50.0;  ///< causal velocity filter of the realistic torque prediction (test run)
  std::function<void(const std::string&)> progress;  ///< one line per step (may be empty)
  bool allow_partial = false;  ///< use the readable part of a damaged log instead of refusing it (reported on progress)
};

/// Runs the study. False with *error (file, reason) when an input cannot be read or is unusable; *damaged (when
/// given) tells whether that was a run log refused as damaged (not --allow-partial: the command's exit 3).
bool runStudy(const StudyOptions& options, std::string* error, bool* damaged = nullptr);

}  // namespace exoid::tools
