#include <cstdio>

#include "commands.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/args.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/tools/run_log.hpp"
#include "exoid/tools/run_table.hpp"

namespace exoid::cli {

namespace {
constexpr char kHelp[] =
    "usage: exoid export --log RUN.lcmlog --out RUN.csv [--truth | --filter HZ] [--model URDF] [--allow-partial]\n\n"
    "Turns a logged run into one CSV row per control tick (1 kHz). Every channel is aligned by tick; a tick\n"
    "missing a needed message is skipped and counted (reported on stderr), never interpolated. A damaged log\n"
    "(bytes that are not a valid event, events that do not decode, a cut-off last event) is read past the\n"
    "damage; how many events were damaged and where the readable part ends are reported on stderr, and the\n"
    "export fails unless --allow-partial is given.\n\n"
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
    "  fp_<right|left>_nx,ny,nz       its moment about the world origin, world coordinates, N m\n\n"
    "options:\n"
    "  --log FILE      lcm-logger file of a run (exoid experiment writes DIR/run.lcmlog)\n"
    "  --out FILE      CSV to write (atomically: no partial file on error)\n"
    "  --truth         export the simulator's ground-truth channel (EXO_TRUTH) instead of the sensors;\n"
    "                  for validation only\n"
    "  --filter HZ     sensors only: add the derivative columns, Butterworth cutoff HZ (e.g. 50)\n"
    "  --model URDF    robot model naming the joints (default config/exo.urdf)\n"
    "  --allow-partial export what is readable from a damaged log (the damage is still reported)\n"
    "  --help          this text\n\n"
    "exit codes: 0 success (with --allow-partial also from a damaged log), 2 bad input (unreadable log, no\n"
    "            usable tick, bad option), 3 the log is damaged (nothing written; see --allow-partial).\n";

int fail(const std::string& msg) {
  std::fprintf(stderr, "exoid export: error: %s\n", msg.c_str());
  return 2;
}
}  // namespace

int cmdExport(int argc, char** argv) {
  tools::Args args;
  args.option("log").option("out").option("filter", "0").option("model", std::string(EXOID_CONFIG_DIR) + "/exo.urdf");
  args.flag("truth").flag("allow-partial").flag("help");
  std::string err;
  if (!args.parse(argc, argv, 2, &err)) return fail(err);
  if (args.has("help")) return std::fputs(kHelp, stdout), 0;
  if (!args.has("log") || !args.has("out")) return fail("--log and --out are required (exoid export --help)");
  tools::ExportOptions opt;
  opt.truth = args.has("truth");
  if (!args.getDouble("filter", opt.filter_hz, &err)) return fail(err);
  if (args.has("filter") && opt.filter_hz <= 0.0) return fail("--filter must be a positive cutoff in Hz");
  Model model;
  if (!buildModelFromUrdfFile(args.get("model"), true, model, &err)) return fail(err);
  tools::RunLog log;
  if (!tools::readRunLog(args.get("log"), model.joint_names, log, &err)) return fail(err);
  if (!log.intact()) {
    std::fprintf(stderr, "exoid export: %s: %s: %s\n", args.has("allow-partial") ? "warning" : "error",
                 args.get("log").c_str(), log.damageReport().c_str());
    if (!args.has("allow-partial")) return 3;
  }
  tools::RunTable table;
  if (!tools::buildRunTable(model, log, opt, table, &err)) return fail(args.get("log") + ": " + err);
  tools::AtomicCsvWriter out;
  if (!out.open(args.get("out"), &err)) return fail(err);
  for (size_t i = 0; i < table.header.size(); ++i) std::fprintf(out.file(), i ? ",%s" : "%s", table.header[i].c_str());
  std::fputc('\n', out.file());
  for (const auto& row : table.rows) {
    for (size_t i = 0; i < row.size(); ++i) std::fprintf(out.file(), i ? ",%.17g" : "%.17g", row[i]);
    std::fputc('\n', out.file());
  }
  if (!out.commit(&err)) return fail(err);
  std::fprintf(stderr, "exoid export: %zu ticks -> %s (%ld ticks skipped for a missing message; %ld log events "
               "rejected%s%s; %ld damaged stretches%s)\n", table.rows.size(), args.get("out").c_str(), table.skipped_ticks,
               log.rejected, log.first_rejection.empty() ? "" : ", first: ", log.first_rejection.c_str(), log.corrupt_events,
               log.truncated ? "; cut off at the end" : "");
  return 0;
}

}  // namespace exoid::cli
