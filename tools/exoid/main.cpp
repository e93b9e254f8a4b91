// exoid: the offline tools on top of the libraries (thin main; the work is in the libraries and commands).
#include <cstdio>
#include <cstring>
#include <string>

#include "commands.hpp"

namespace {
struct Command {
  const char* name;
  int (*run)(int, char**);
  const char* summary;
};
const Command kCommands[] = {
    {"model", exoid::cli::cmdModel, "print a model summary: links, joints, masses, total mass, standing CoM, base parameters"},
    {"regressor", exoid::cli::cmdRegressor, "evaluate the joint torque regressor K(q, v, dv) for states from a CSV"},
    {"base-params", exoid::cli::cmdBaseParams, "structural base parameters: which parameters are identifiable, alone or combined"},
    {"experiment", exoid::cli::cmdExperiment, "closed-loop run: sim + controller over LCM in a private network namespace, logged and summarised"},
    {"export", exoid::cli::cmdExport, "a logged run as one CSV row per tick (sensors, or --truth)"},
    {"identify", exoid::cli::cmdIdentify, "batch identification (OLS / WLS-R / WLS-C / WLS-RC, truncated SVD) from logs or measured CSVs"},
    {"study", exoid::cli::cmdStudy, "the thesis's comparison protocol (Tables II and C.1) on training, validation and test runs"},
    {"calibrate", exoid::cli::cmdCalibrate, "calibration run: the pelvis held in a harness, the legs swinging (for diagnose --calibration)"},
    {"diagnose", exoid::cli::cmdDiagnose, "find what the rigid-body model leaves out (friction, offsets, gain, delay, ...) from the residual"},
    {"render", exoid::cli::cmdRender, "a logged run as pictures: MuJoCo's renderer, headless, to MP4/GIF/PNG with the CoMs and plate forces"},
};

void usage(FILE* out) {
  std::fprintf(out,
               "exoid - inertial parameter identification for a bipedal lower-limb exoskeleton\n\n"
               "usage: exoid <command> [options]      exoid <command> --help for the command's options\n\ncommands:\n");
  for (const Command& c : kCommands) std::fprintf(out, "  %-12s %s\n", c.name, c.summary);
  std::fprintf(out, "\nexit codes: 0 success, 2 bad input (a one-line message on stderr names the problem).\n"
                    "conventions and file formats: docs/conventions.md, docs/data-formats.md\n");
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h") || !std::strcmp(argv[1], "help")) {
    usage(stdout);
    return argc < 2 ? 2 : 0;
  }
  for (const Command& c : kCommands)
    if (!std::strcmp(argv[1], c.name)) return c.run(argc, argv);
  std::fprintf(stderr, "exoid: error: unknown command '%s' (exoid --help lists them)\n", argv[1]);
  return 2;
}
