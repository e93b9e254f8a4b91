#include <cstdio>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/common/process_main.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::cli {

namespace cmd_base_params {  // this file's own names: the exoid binary is a unity build
// The stacked regressor (samples * nv rows x p columns of doubles) must fit comfortably in memory.
constexpr double kMaxStackedBytes = 2.0 * (1 << 30);

int fail(const std::string& msg) { return common::badInput("exoid base-params", msg); }
}  // namespace cmd_base_params

int cmdBaseParams(int argc, char** argv) {
  using namespace cmd_base_params;
  CLI::App app{
      "Structural base parameters (thesis section II-E, Gautier 1990): the regressor is stacked over N random\n"
      "states (any configuration, velocity, acceleration and base motion) and factorised by column-pivoted QR.\n"
      "Prints how many base parameters there are, which standard parameters are identifiable alone, the linear\n"
      "combinations in which the others are identifiable, and the parameters that have no effect at all.",
      "exoid base-params"};
  common::configureCli(app);
  std::string path;
  bool floating_base = false;
  BaseParameterOptions opt;
  int64_t samples = opt.samples, seed = static_cast<int64_t>(opt.seed);
  app.add_option("--model", path, "robot description")->required()->type_name("URDF");
  app.add_flag("--floating-base", floating_base, "root link on a 6-dof free joint (default: fixed)");
  app.add_option("--samples", samples,
                 "random states stacked; N times the number of generalized velocities must reach the number\n"
                 "of parameters, and the stacked regressor must fit in 2 GiB")
      ->transform(common::strictInteger(1, 100000000))->type_name("N");
  app.add_option("--seed", seed, "random seed")->transform(common::strictInteger(0))->type_name("S");
  app.add_option("--tolerance", opt.tolerance, "pivots below T times the largest count as zero")
      ->transform(common::strictNumber(0.0, 1.0, true))->type_name("T");
  app.footer("exit codes: 0 success, 2 bad input.");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(path, floating_base, model, &err)) return fail(err);
  const int p = model.nparams(), nv = model.nv;
  if (nv > 0 && samples * nv < p)
    return fail("--samples " + std::to_string(samples) + ": " + std::to_string(samples * nv) + " regressor rows (" +
                std::to_string(nv) + " per sample) cannot reveal " + std::to_string(p) +
                " parameters; use at least " + std::to_string((p + nv - 1) / nv));
  if (static_cast<double>(samples) * nv * p * sizeof(double) > kMaxStackedBytes)
    return fail("--samples " + std::to_string(samples) + ": the stacked regressor (" + std::to_string(samples * nv) +
                " x " + std::to_string(p) + ") would not fit in 2 GiB");
  opt.samples = static_cast<int>(samples);
  opt.seed = static_cast<uint64_t>(seed);
  std::fputs(describeBaseParameters(model, computeBaseParameters(model, opt)).c_str(), stdout);
  return 0;
}

}  // namespace exoid::cli
