#include <cstdio>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/csv.hpp"
#include "exoid/tools/state_columns.hpp"

namespace exoid::cli {

namespace cmd_regressor {  // this file's own names: the exoid binary is a unity build
int fail(const std::string& msg) { return common::badInput("exoid regressor", msg); }

/// W for every sample: one CSV row per sample and generalized coordinate (atomically).
bool writeRegressor(const Model& model, const tools::CsvTable& table, const tools::StateColumns& columns,
                    const std::string& states_path, const std::string& out_path, std::string* err) {
  const std::vector<std::string> row_names = model.coordinateNames();
  tools::AtomicCsvWriter out;
  if (!out.open(out_path, err)) return false;
  FILE* f = out.file();
  std::fputs("sample,row", f);
  for (const std::string& n : model.paramNames()) std::fprintf(f, ",%s", n.c_str());
  std::fputc('\n', f);
  Data data(model);
  State state = State::zero(model);
  for (size_t i = 0; i < table.rows.size(); ++i) {
    if (!columns.read(table.rows[i], state, err))
      return *err = states_path + ":" + std::to_string(table.lines.at(i)) + ": " + *err, false;  // readCsv's lines
    computeJointTorqueRegressor(model, data, state);
    for (int r = 0; r < model.nv; ++r) {
      std::fprintf(f, "%zu,%s", i, row_names[r].c_str());
      for (int c = 0; c < data.K.cols(); ++c) std::fprintf(f, ",%.17g", data.K(r, c));
      std::fputc('\n', f);
    }
  }
  return out.commit(err);
}
}  // namespace cmd_regressor

int cmdRegressor(int argc, char** argv) {
  using namespace cmd_regressor;
  CLI::App app{
      "Evaluates the joint torque regressor K(q, v, dv) of the seed thesis (eqs. 10-14 with the friction\n"
      "columns of eqs. 2.48-2.49) for every sample of STATES.csv and writes the stacked W, so that W * phi\n"
      "gives the generalized forces for any parameter vector phi.",
      "exoid regressor"};
  common::configureCli(app);
  std::string model_path, states_path, out_path;
  bool floating_base = false;
  double g = 9.81;
  app.add_option("--model", model_path,
                 "robot (revolute, continuous, fixed joints; fixed links lumped into their parent)")
      ->required()->type_name("URDF");
  app.add_flag("--floating-base", floating_base, "root link on a 6-dof free joint (default: root fixed to the world)");
  app.add_option("--states", states_path,
                 "input CSV, one row per sample, header row, numeric cells, no NaN/Inf\n"
                 "(UTF-8 byte-order mark and CRLF line ends accepted):\n"
                 "  q_<joint>, v_<joint>, a_<joint>   for every URDF joint (rad, rad/s, rad/s^2)\n"
                 "with --floating-base also:\n"
                 "  base_qw, base_qx, base_qy, base_qz  orientation world <- base, Hamilton, w first\n"
                 "  base_wx, base_wy, base_wz           angular velocity, base coordinates (rad/s)\n"
                 "  base_vx, base_vy, base_vz           velocity of the base origin, base coords (m/s;\n"
                 "                                      optional: it does not enter K)\n"
                 "  base_dwx, base_dwy, base_dwz        angular acceleration, base coords (rad/s^2)\n"
                 "  base_ax, base_ay, base_az           classical acceleration of the base origin,\n"
                 "                                      base coords, gravity NOT included (m/s^2)\n"
                 "optional base_px..pz; other columns (t, tau_*, ...) are ignored.")
      ->required()->type_name("FILE");
  app.add_option("--out", out_path,
                 "output CSV: header 'sample,row,<parameter names>'; one row per sample and\n"
                 "generalized coordinate; row = base_nx, base_ny, base_nz, base_fx, base_fy, base_fz\n"
                 "(moment then force on the base about its origin, base coordinates; floating base\n"
                 "only) or the joint name. Parameters: per link in tree order\n"
                 "<link>.m, .mcx, .mcy, .mcz, .Ixx, .Ixy, .Ixz, .Iyy, .Iyz, .Izz (link frame, about the\n"
                 "link origin, inertia-tensor convention), then per joint <joint>.fv, <joint>.fc.\n"
                 "Written atomically: on any error no output file is left behind.")
      ->required()->type_name("FILE");
  app.add_option("--gravity", g, "gravity magnitude, m/s^2, along -z of the world / root link")
      ->transform(common::strictNumber(0.0, 1000.0))->type_name("G");
  app.footer(
      "exit codes: 0 success, 2 bad input (unknown joint name, missing column, NaN/Inf, unreadable or\n"
      "malformed URDF or CSV; a one-line message names the problem).");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(model_path, floating_base, model, &err, g)) return fail(err);
  tools::CsvTable table;
  if (!tools::readCsv(states_path, table, &err)) return fail(err);
  tools::StateColumns columns;
  if (!columns.bind(model, table, &err)) return fail(states_path + ": " + err);

  if (!writeRegressor(model, table, columns, states_path, out_path, &err)) return fail(err);
  std::fprintf(stderr, "exoid regressor: %zu samples x %d rows x %d parameters -> %s\n", table.rows.size(), model.nv,
               model.nparams(), out_path.c_str());
  return 0;
}

}  // namespace exoid::cli
