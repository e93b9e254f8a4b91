#include <cstdio>
#include <cstring>
#include <limits>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/inertial.hpp"
#include "exoid/model/urdf.hpp"
#include "exoid/tools/perturb_inertials.hpp"
#include "exoid/tools/urdf_inertials.hpp"
#include "exoid/tools/wearer_urdf.hpp"

namespace exoid::cli {

namespace cmd_model {  // this file's own names: the exoid binary is a unity build

// exoid model perturb: a +-r prior URDF (tools/perturb_inertials.hpp).
int cmdModelPerturb(int argc, char** argv) {
  CLI::App app{
      "Writes a copy of a URDF with every link's inertial parameters perturbed at random, physically consistent:\n"
      "mass, each centre-of-mass coordinate (link frame) and each principal moment of inertia about the CoM\n"
      "(nominal principal axes) multiplied by an independent factor 1 + u, u uniform in [-R, R], the moments\n"
      "redrawn until they satisfy the triangle inequality. Deterministic for a seed. For running the controller\n"
      "(exoid experiment --controller-model) and the estimator from a wrong prior (issue 8's +-25 % prior).",
      "exoid model perturb"};
  common::configureCli(app);
  std::string path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf", out;
  double relative = 0.25;
  int64_t seed = 1;
  bool floating_base = true;
  app.add_option("--model", path, "robot description to perturb (default config/exo.urdf)")->type_name("URDF");
  app.add_option("--relative", relative, "largest relative change R of each quantity (default 0.25)")
      ->transform(common::strictNumber(0.0, 0.9))->type_name("R");
  app.add_option("--seed", seed, "random seed (default 1)")
      ->transform(common::strictInteger(0, std::numeric_limits<int64_t>::max()))->type_name("N");
  app.add_option("--out", out, "the perturbed URDF to write")->required()->type_name("URDF");
  app.add_flag("--fixed-base{false}", floating_base,
               "the root link is fixed to the world (default: a floating base, as the exoskeleton)");
  app.footer("Prints one line per link: nominal and perturbed mass. exit codes: 0 success, 2 bad input\n"
             "(unreadable or malformed URDF, bad option, unwritable output).");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  Model model;
  Eigen::VectorXd phi;
  if (!buildModelFromUrdfFile(path, floating_base, model, &err) ||
      !tools::perturbInertials(model, relative, static_cast<uint64_t>(seed), phi, &err) ||
      !tools::writeUrdfWithInertials(path, model, phi, out, &err)) {
    std::fprintf(stderr, "exoid model perturb: error: %s\n", err.c_str());
    return 2;
  }
  double m0 = 0.0, m1 = 0.0;
  for (int b = 0; b < model.nbodies; ++b) {
    const double a = model.phi[model.bodyParamIndex(b)], p = phi[model.bodyParamIndex(b)];
    m0 += a;
    m1 += p;
    std::printf("%-22s mass %8.4f -> %8.4f kg (%+5.1f %%)\n", model.body_names[static_cast<size_t>(b)].c_str(), a, p,
                a > 0.0 ? 100.0 * (p / a - 1.0) : 0.0);
  }
  std::printf("total mass %.4f -> %.4f kg; wrote %s (seed %lld, relative %.3f)\n", m0, m1, out.c_str(),
              static_cast<long long>(seed), relative);
  return 0;
}

void printStandingCom(const Model& model);

// exoid model wearer: the exo URDF plus the wearer from de Leva's table (tools/wearer_urdf.hpp, docs/wearer.md).
int cmdModelWearer(int argc, char** argv) {
  CLI::App app{
      "Writes the clinic's prior of the exoskeleton with its wearer: the exoskeleton URDF plus the wearer's 16 body\n"
      "segments from de Leva (1996) Table 4 at the given mass, height and sex (masses, CoM positions and radii of\n"
      "gyration scaled to the height), each a link on a fixed joint to the exoskeleton link it rides on (thighs,\n"
      "shanks, feet; head, trunk and arms rigid on the pelvis), and a massless link 'wearer_lumbar' on the pelvis at\n"
      "the lumbar pivot, where the upper body turns (the controller's CoM observer takes its lever from it).\n"
      "--variation draws a person who is not the table (each mass, CoM fraction and radius x (1 + U[-V, V]), seeded;\n"
      "masses renormalised to --mass).",
      "exoid model wearer"};
  common::configureCli(app);
  std::string path = std::string(EXOID_CONFIG_DIR) + "/exo.urdf", out, sex;
  WearerSpec spec;
  int64_t seed = 1;
  app.add_option("--model", path, "exoskeleton URDF (default config/exo.urdf)")->type_name("URDF");
  app.add_option("--mass", spec.mass_kg, "wearer's body mass in kg")->required()
      ->transform(common::strictNumber(1.0, 300.0))->type_name("KG")->default_str("");
  app.add_option("--height", spec.height_m, "wearer's height (stature) in m")->required()
      ->transform(common::strictNumber(1.0, 2.5))->type_name("M")->default_str("");
  app.add_option("--sex", sex, "m or f (de Leva's male or female table)")->required()
      ->check(CLI::IsMember({"m", "f"}))->type_name("m|f");
  app.add_option("--seed", seed, "seed of the variation draw (default 1)")
      ->transform(common::strictInteger(0, std::numeric_limits<int64_t>::max()))->type_name("N");
  app.add_option("--variation", spec.variation, "relative variation V of each segment parameter (default 0: the table)")
      ->transform(common::strictNumber(0.0, 0.5))->type_name("V");
  app.add_option("--out", out, "the prior URDF to write")->required()->type_name("URDF");
  app.footer("Prints one line per wearer segment, then the prior's total mass and standing CoM.\n"
             "exit codes: 0 success, 2 bad input (unreadable URDF without the exo's links, bad option, unwritable\n"
             "output).");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  spec.sex = sex == "f" ? Sex::Female : Sex::Male;
  spec.seed = static_cast<uint64_t>(seed);
  std::string err;
  WearerMount mount;
  Model prior;
  if (!tools::writeWearerPrior(path, spec, out, &mount, &err) || !buildModelFromUrdfFile(out, true, prior, &err)) {
    std::fprintf(stderr, "exoid model wearer: error: %s\n", err.c_str());
    return 2;
  }
  std::printf("%-20s %-16s %9s  %s\n", "segment", "on link", "mass [kg]", "CoM in link frame [m]");
  double wearer_mass = 0.0;
  for (const MountedSegment& s : mount.segments) {
    wearer_mass += s.mass;
    std::printf("%-20s %-16s %9.4f  (%.4f, %.4f, %.4f)\n", s.segment.c_str(), s.link.c_str(), s.mass, s.com.x(),
                s.com.y(), s.com.z());
  }
  std::printf("\nWearer %.4f kg (%s, %.3f m); exoskeleton + wearer in %s\n", wearer_mass,
              spec.sex == Sex::Male ? "male" : "female", spec.height_m, out.c_str());
  printStandingCom(prior);
  return 0;
}

/// One line per moving link: parent, joint, axis, mass, CoM.
void printBodies(const Model& model) {
  std::printf(" #  %-22s %-22s %-16s %-22s %9s  %s\n", "link", "parent", "joint", "axis (link frame)", "mass [kg]",
              "CoM in link frame [m]");
  for (int b = 0; b < model.nbodies; ++b) {
    const int j = model.jointOfBody(b);
    const Vector10d phi = model.phi.segment<10>(model.bodyParamIndex(b));
    const Eigen::Vector3d c = phi[0] > 0 ? Eigen::Vector3d(phi.segment<3>(1) / phi[0]) : Eigen::Vector3d::Zero();
    char axis[64];
    if (j >= 0)
      std::snprintf(axis, sizeof axis, "(%.3f, %.3f, %.3f)", model.joint_axis[b].x(), model.joint_axis[b].y(),
                    model.joint_axis[b].z());
    else
      std::snprintf(axis, sizeof axis, "free (6 dof)");
    std::printf("%2d  %-22s %-22s %-16s %-22s %9.4f  (%.4f, %.4f, %.4f)\n", b, model.body_names[b].c_str(),
                model.parent[b] < 0 ? (model.floating_base ? "(world, free joint)" : "(fixed root)")
                                    : model.body_names[model.parent[b]].c_str(),
                j >= 0 ? model.joint_names[j].c_str() : "-", axis, phi[0], c.x(), c.y(), c.z());
  }
}

/// The total mass and the CoM in the standing pose (q = 0), also relative to the soles' midpoint when the model
/// has soles.
void printStandingCom(const Model& model) {
  DynamicsData dyn(model);
  const State standing = State::zero(model);
  forwardKinematics(model, dyn.kin, standing);
  centroidal(model, dyn);
  std::printf("\nTotal mass: %.4f kg\n", model.totalMass());
  std::printf("Centre of mass in the standing pose (q = 0), %s frame: (%.4f, %.4f, %.4f) m\n",
              model.floating_base ? "base" : "root", dyn.com.x(), dyn.com.y(), dyn.com.z());
  const int rs = model.frameIndex("right_sole"), ls = model.frameIndex("left_sole");
  if (rs >= 0 && ls >= 0) {
    auto at = [&](int f) {
      const Model::Frame& fr = model.frames[f];
      return Eigen::Vector3d(dyn.kin.p[fr.body] + dyn.kin.R[fr.body] * fr.position);
    };
    const Eigen::Vector3d mid = 0.5 * (at(rs) + at(ls));
    const Eigen::Vector3d rel = dyn.com - mid;
    std::printf("  relative to the midpoint between the soles: (%.4f, %.4f, %.4f) m (height %.3f m)\n", rel.x(),
                rel.y(), rel.z(), rel.z());
  }
}

}  // namespace cmd_model

int cmdModel(int argc, char** argv) {
  using namespace cmd_model;
  if (argc >= 3 && std::strcmp(argv[2], "perturb") == 0) return cmdModelPerturb(argc - 1, argv + 1);
  if (argc >= 3 && std::strcmp(argv[2], "wearer") == 0) return cmdModelWearer(argc - 1, argv + 1);
  CLI::App app{
      "Prints the model exoid builds from a URDF: every moving link (body) in tree order with its parent, joint,\n"
      "joint axis, mass and centre of mass; the total mass; the centre of mass in the standing pose (all joints\n"
      "at 0, base at the origin with identity orientation); and the number of structural base parameters.",
      "exoid model"};
  common::configureCli(app);
  std::string path;
  bool floating_base = false;
  double g = 9.81;
  app.add_option("--model", path, "robot description (revolute, continuous and fixed joints; fixed links are lumped)")
      ->required()->type_name("URDF");
  app.add_flag("--floating-base", floating_base,
               "the root link is a floating base (6-dof free joint); default: fixed to the world");
  app.add_option("--gravity", g, "gravity magnitude in m/s^2 along -z of the world")
      ->transform(common::strictNumber(0.0, 1000.0))->type_name("G");
  app.footer("exoid model perturb --help: write a randomly perturbed (+-R, consistent) copy of a URDF.\n"
             "exoid model wearer --help: write the exoskeleton URDF with its wearer (de Leva 1996 segments).\n"
             "exit codes: 0 success, 2 bad input (unreadable or malformed URDF, bad option).");
  if (const int code = common::parseCli(app, argc - 1, argv + 1); code >= 0) return code;
  std::string err;
  Model model;
  if (!buildModelFromUrdfFile(path, floating_base, model, &err, g)) {
    std::fprintf(stderr, "exoid model: error: %s\n", err.c_str());
    return 2;
  }
  std::printf("Model '%s' from %s: %s base, %d moving links, %d joints, %d generalized velocities, %d parameters "
              "(10 per link + 2 friction per joint)\n\n",
              model.name.c_str(), path.c_str(), model.floating_base ? "floating" : "fixed",
              model.nbodies, model.njoints, model.nv, model.nparams());
  printBodies(model);
  printStandingCom(model);
  const BaseParameters base = computeBaseParameters(model);
  int friction = 2 * model.njoints;
  std::printf("Structural base parameters: %d of %d (%d inertial + %d friction); exoid base-params lists them\n",
              base.rank, model.nparams(), base.rank - friction, friction);
  return 0;
}

}  // namespace exoid::cli
