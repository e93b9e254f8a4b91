// exoid export: a logged run as one CSV row per tick. Thin: options -> intake::readRunLog, tools::buildRunTable ->
// the CSV.
#include <cstdio>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/intake/run_log.hpp"
#include "exoid/tools/run_table.hpp"

namespace exoid::cli {

namespace cmd_export {  // this file's own names: the exoid binary is a unity build
constexpr char kDescription[] =
    "Turns a logged run into one CSV row per control tick (1 kHz). Every channel is aligned by tick; a tick\n"
    "missing a needed message is skipped and counted (reported on stderr), never interpolated. A damaged log\n"
    "(bytes that are not a valid event, events that do not decode, a cut-off last event) is read past the\n"
    "damage; how many events were damaged and where the readable part ends are reported on stderr, and the\n"
    "export fails unless --allow-partial is given.";

constexpr char kFooter[] =
    "columns (docs/data-formats.md):\n"
    "  t                              seconds (tick * 1e-3)\n"
    "  q_<joint>                      joint encoders (rad)\n"
    "  v_<joint>, a_<joint>           joint velocity, acceleration: exact with --truth; with --filter HZ\n"
    "                                 from the encoders by zero-phase 2nd-order Butterworth + differences\n"
    "                                 (thesis III-E); left out otherwise (measured accelerations do not exist)\n"
    "  base_qw, base_qx, base_qy, base_qz  orientation world <- base (IMU; exact with --truth)\n"
    "  base_wx..wz                    angular velocity, base coordinates (gyro; exact with --truth)\n"
    "  base_vx..vz                    velocity of the base origin, base coordinates (--truth only)\n"
    "  base_dwx..dwz                  angular acceleration, base coordinates (--truth, or --filter)\n"
    "  base_ax..az                    classical acceleration of the base origin, base coordinates, gravity\n"
    "                                 excluded (accelerometer + R^T g; exact with --truth)\n"
    "  base_px..pz                    base origin in the world (--truth only: not measured by the robot)\n"
    "  tau_<joint>                    actuated joints: torque sensors (applied torque with --truth), N m\n"
    "  fp_<right|left>_fx,fy,fz       force ON the foot, world coordinates, N (minus the plate's reading)\n"
    "  fp_<right|left>_nx,ny,nz       its moment about the world origin, world coordinates, N m\n"
    "  com_x..z                       --truth only: the whole system's CoM, world, m (wearer included)\n"
    "  trunk_angle_x..z, trunk_rate_x..z  --truth of a wearer run only: the lumbar hinges (the upper body on the\n"
    "                                 pelvis, intrinsic x-y-z), rad, rad/s\n"
    "  trunk_com_x..z                 --truth of a wearer run only: the upper body's CoM, world, m\n\n"
    "exit codes: 0 success (with --allow-partial also from a damaged log), 2 bad input (unreadable log, no\n"
    "            usable tick, bad option), 3 the log is damaged (nothing written; see --allow-partial).";

int fail(const std::string& msg) { return common::badInput("exoid export", msg); }

/// The table as CSV (header row, %.17g cells), written atomically.
bool writeTable(const tools::RunTable& table, const std::string& path, std::string* err) {
  tools::AtomicCsvWriter out;
  if (!out.open(path, err)) return false;
  for (size_t i = 0; i < table.header.size(); ++i) std::fprintf(out.file(), i ? ",%s" : "%s", table.header[i].c_str());
  std::fputc('\n', out.file());
  for (const auto& row : table.rows) {
    for (size_t i = 0; i < row.size(); ++i) std::fprintf(out.file(), i ? ",%.17g" : "%.17g", row[i]);
    std::fputc('\n', out.file());
  }
  return out.commit(err);
}
}  // namespace cmd_export

int cmdExport(int argc, char** argv) {
  using namespace cmd_export;
  CLI::App app{kDescription, "exoid export"};
  common::configureCli(app);
  std::string log_path, out_path, model_path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf";
  tools::ExportOptions opt;
  app.add_option("--log", log_path, "lcm-logger file of a run (exoid experiment writes DIR/run.lcmlog)")
      ->required()->type_name("FILE");
  app.add_option("--out", out_path, "CSV to write (atomically: no partial file on error)")->required()->type_name("FILE");
  app.add_flag("--truth", opt.truth,
                             "export the simulator's ground-truth channel (EXO_TRUTH) instead of the sensors;\n"
               "for validation only");
  app.add_option("--filter", opt.filter_hz, "sensors only: add the derivative columns, Butterworth cutoff HZ (e.g. 50);\n"
                 "below the Nyquist frequency, 500 Hz; absent: no derivative columns")
      ->transform(common::strictNumber(1e-6, 1e6))->type_name("HZ")->default_str("");
  app.add_option("--model", model_path, "robot model naming the joints")->type_name("URDF");
  bool allow_partial = false;
  app.add_flag("--allow-partial", allow_partial, "export what is readable from a damaged log (the damage is still reported)");
  app.footer(kFooter);
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(model_path, true, model, &err)) return fail(err);
  intake::RunLog log;
  if (!intake::readRunLog(log_path, model.joint_names, log, &err)) return fail(err);
  if (!log.intact()) {
    std::fprintf(stderr, "exoid export: %s: %s: %s\n", allow_partial ? "warning" : "error", log_path.c_str(),
                 log.damageReport().c_str());
    if (!allow_partial) return 3;
  }
  tools::RunTable table;
  if (!tools::buildRunTable(model, log, opt, table, &err)) return fail(log_path + ": " + err);
  if (!writeTable(table, out_path, &err)) return fail(err);
  std::fprintf(stderr, "exoid export: %zu ticks -> %s (%ld ticks skipped for a missing message; %ld repeated and "
               "%ld out-of-order messages dropped; %ld log events rejected%s%s; %ld damaged stretches%s)\n",
               table.rows.size(), out_path.c_str(), table.skipped_ticks, table.repeated_messages,
               table.out_of_order_messages,
               log.rejected, log.first_rejection.empty() ? "" : ", first: ", log.first_rejection.c_str(),
               log.damage.corrupt_events, log.damage.truncated ? "; cut off at the end" : "");
  return 0;
}

}  // namespace exoid::cli
