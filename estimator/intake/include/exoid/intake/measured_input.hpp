#pragma once
// Recorded data -> estimator::MeasuredSample, one sample at a time (memory does not grow with the data
// length): a run log of `exoid experiment` / `exoid calibrate` (streamRunLog) or a CSV of measured data
// (streamMeasuredCsv). What `exoid identify`, `diagnose` and `study` read (tools/identify_input.hpp turns the
// samples into regressor rows). Damaged input is refused naming the file, where (byte / line, column) and
// what; what may be skipped instead (--allow-partial, --skip-bad-rows) is counted in InputStats.
#include <functional>
#include <map>
#include <string>

#include "exoid/estimator/dataset.hpp"
#include "exoid/estimator/sole_placement.hpp"
#include "exoid/intake/log_events.hpp"
#include "exoid/model/model.hpp"

namespace exoid::intake {

/// Which samples of a run log to use.
enum class LogPipeline {
  Sensors,  ///< EXO_STATE + both plates: encoders, torque sensors, IMU, plates (what a lab has)
  Truth,    ///< EXO_TRUTH (exact state, applied torques) + both plates: the thesis protocol's input
};

struct InputStats {
  long samples = 0;                 ///< handed to the sink
  long skipped = 0;                 ///< bad rows / incomplete or out-of-order ticks dropped
  std::map<std::string, long> why;  ///< skipped, by reason
  std::string first_skip;           ///< where and why the first one was skipped
  long rejected_events = 0;         ///< log events the adapters rejected (LCM only)
  LogDamage damage;                 ///< LCM only: damage to the log's framing
  std::string damage_report;        ///< LCM only: damageReport() of the log, "" when intact
  bool refused_damaged = false;     ///< the read failed because the log is damaged (not allowed partial)
  estimator::SoleTilt sole_tilt;    ///< the soles' tilt fitted over this file (tools::SourceOptions::fit_sole_tilt)
  /// The soles' common offset on their plates fitted to this file (tools::SourceOptions::fit_sole_placement)
  estimator::SolePlacement sole_placement;

  /// Counts one skipped row/tick/event under `reason`; the first one skipped is remembered with `where`.
  void skip(const std::string& reason, const std::string& where) {
    ++skipped;
    ++why[reason];
    if (first_skip.empty()) first_skip = where + ": " + reason;
  }
};

using SampleSink = std::function<bool(const estimator::MeasuredSample&, std::string* error)>;

/// Streams a run log in tick order, assembled by the one TickAssembly (window kLogLagWindow). A tick missing a
/// needed channel is skipped and counted; a repeat of a tick's message (the first kept) and a message for a
/// tick already passed on are counted. A damaged log (damaged stretches, a
/// cut-off tail, needed events the adapters reject) is refused (false, stats.refused_damaged, *error names the
/// file and gives damageReport(): count, first bad byte, where the readable part ends) unless allow_partial:
/// then its readable part is used and the damage is in stats. feet: the model's right and left foot bodies.
/// False with *error also if the file is not a readable LCM log, holds none of the needed channels, or the
/// sink fails.
bool streamRunLog(const std::string& path, const Model& model, LogPipeline pipeline, const int feet[2],
                  bool allow_partial, const SampleSink& sink, InputStats& stats, std::string* error);

/// Streams a measured-data CSV (docs/identification.md): `t`, `q_<joint>` for every joint, `tau_<joint>`
/// for every actuated joint (URDF effort limit > 0; absent columns of unactuated joints read as 0),
/// optional `v_<joint>` and `a_<joint>` (all joints or none), and for a floating base `base_qw..qz`,
/// `base_wx..wz`, `base_ax..az`, `fp_<right|left>_<fx..nz>`, optional `base_dwx..dwz`, `base_px..pz`.
/// Rejected rows: wrong cell count (also a truncated last line), a cell that is not a finite number, an absurd
/// value (|q| beyond the joint limits by more than 1 rad or above 100 rad without limits, |v| > 1e3 rad/s,
/// |a| > 1e5 rad/s^2, |tau| > 100 x the effort limit or 1e5, a quaternion off unit norm by more than 1e-3,
/// |force| > 1e6 N), and a time out of order: not after the last accepted row's, or more than kTimeJump
/// typical steps after it, unless the next row confirms it (then the recording had a gap). A wild time costs
/// its own row only; a time that goes back and the next rows follow it (two recordings in one file, a clock
/// reset) is an error even with skip_bad_rows. Without skip_bad_rows the first bad row is an error naming
/// `file:line` (as an editor counts, the header's line included), the column (number and name) and the value.
bool streamMeasuredCsv(const std::string& path, const Model& model, const int feet[2], bool skip_bad_rows,
                       const SampleSink& sink, InputStats& stats, std::string* error);

/// A time step more than this many typical steps (the median of the last accepted ones) is a jump: a wild
/// value unless the next row continues from it.
constexpr double kTimeJump = 1000.0;

}  // namespace exoid::intake
