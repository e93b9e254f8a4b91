#include <cstdio>

#include "commands.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/args.hpp"

namespace exoid::cli {

namespace {
constexpr char kHelp[] =
    "usage: exoid base-params --model URDF [--floating-base] [--samples N] [--seed S] [--tolerance T]\n\n"
    "Structural base parameters (thesis section II-E, Gautier 1990): the regressor is stacked over N random\n"
    "states (any configuration, velocity, acceleration and base motion) and factorised by column-pivoted QR.\n"
    "Prints how many base parameters there are, which standard parameters are identifiable alone, the linear\n"
    "combinations in which the others are identifiable, and the parameters that have no effect at all.\n\n"
    "options:\n"
    "  --model URDF       robot description\n"
    "  --floating-base    root link on a 6-dof free joint (default: fixed)\n"
    "  --samples N        random states stacked (default 200)\n"
    "  --seed S           random seed (default 1)\n"
    "  --tolerance T      pivots below T times the largest count as zero (default 1e-9)\n"
    "  --help             this text\n\n"
    "exit codes: 0 success, 2 bad input.\n";
}  // namespace

int cmdBaseParams(int argc, char** argv) {
  tools::Args args;
  args.option("model").option("samples", "200").option("seed", "1").option("tolerance", "1e-9");
  args.flag("floating-base").flag("help");
  std::string err;
  BaseParameterOptions opt;
  long samples = 0, seed = 0;
  const bool ok = args.parse(argc, argv, 2, &err);
  if (ok && args.has("help")) return std::fputs(kHelp, stdout), 0;
  if (!ok || !args.getInt("samples", samples, &err) || !args.getInt("seed", seed, &err) ||
      !args.getDouble("tolerance", opt.tolerance, &err)) {
    std::fprintf(stderr, "exoid base-params: error: %s\n", err.c_str());
    return 2;
  }
  if (!args.has("model")) return std::fputs("exoid base-params: error: --model URDF is required\n", stderr), 2;
  if (samples < 1 || opt.tolerance <= 0.0)
    return std::fputs("exoid base-params: error: --samples must be >= 1 and --tolerance > 0\n", stderr), 2;
  opt.samples = static_cast<int>(samples);
  opt.seed = static_cast<uint64_t>(seed);
  Model model;
  if (!buildModelFromUrdfFile(args.get("model"), args.has("floating-base"), model, &err)) {
    std::fprintf(stderr, "exoid base-params: error: %s\n", err.c_str());
    return 2;
  }
  std::fputs(describeBaseParameters(model, computeBaseParameters(model, opt)).c_str(), stdout);
  return 0;
}

}  // namespace exoid::cli
