#include <cstdio>
#include <cstring>

#include "commands.hpp"
#include "exoid/common/cli.hpp"
#include "exoid/estimator/base_parameters.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/regressor.hpp"
#include "exoid/model/urdf.hpp"

namespace exoid::cli {

int cmdModel(int argc, char** argv) {
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
  app.footer("exit codes: 0 success, 2 bad input (unreadable or malformed URDF, bad option).");
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
  const BaseParameters base = computeBaseParameters(model);
  int friction = 2 * model.njoints;
  std::printf("Structural base parameters: %d of %d (%d inertial + %d friction); exoid base-params lists them\n",
              base.rank, model.nparams(), base.rank - friction, friction);
  return 0;
}

}  // namespace exoid::cli
