#include "base_signal_options.hpp"

#include "exoid/common/cli.hpp"
#include "exoid/estimator/sole_placement.hpp"

namespace exoid::cli {

void addBaseSignalOptions(CLI::App& app, tools::BaseSignals& b) {
  app.add_option("--base-orientation", b.orientation, "sensors pipeline: base orientation from leg kinematics (the feet "
                 "flat and still on the plates) corrected for the soles' tilt on their contacts, which the IMU sees: "
                 "'plates' (the tilt a linear function of the plates' wrenches, its coefficients fitted to the IMU over "
                 "the whole file, each axis's columns chosen by BIC), 'fused' (the IMU's correction below "
                 "--orientation-cutoff), or the 'imu' alone")->check(CLI::IsMember({"plates", "fused", "imu"}));
  app.add_option("--base-rate", b.rate, "sensors pipeline: the base's angular velocity and acceleration from the 'legs' "
                 "(feet flat and still on the plates: the rotation the encoders give, differentiated as the joints' "
                 "angles) or the 'gyro' (its white noise differentiated is the larger error)")
      ->check(CLI::IsMember({"legs", "gyro"}));
  app.add_option("--base-acceleration", b.acceleration, "sensors pipeline: the base's linear acceleration from the "
                 "'legs' (the base position the feet give, differentiated twice as the joints' angles; gravity and the "
                 "plates' wrenches then turn with the same orientation) or the 'accelerometer'")
      ->check(CLI::IsMember({"legs", "accelerometer"}));
  app.add_option("--orientation-cutoff", b.orientation_cutoff_hz, "--base-orientation fused: Hz below which the IMU, above "
                 "which the legs give the orientation; with the fused orientation identify's rank rule's processing "
                 "check uses it for the IMU's rate and acceleration")
      ->transform(common::strictNumber(0.01, 400.0))->type_name("HZ");
  app.add_option_function<std::vector<std::string>>(
         "--sole-on-plate",
         [&b](const std::vector<std::string>& specs) {
           for (const std::string& spec : specs) {
             if (spec == "fit") {
               b.fit_sole_placement = true;
               continue;
             }
             std::string why;
             if (!estimator::parseSoleOnPlate(spec, b.sole_on_plate, &why)) throw CLI::ValidationError(why);
           }
         },
         "floating base: where a sole stands on its plate, SIDE:X,Y[,Z] (SIDE right or left; the sole frame's origin "
         "minus the plate's reported sensor origin, lab axes, m; once per side), and/or 'fit': the soles' common "
         "offset (x, y) fitted to each file's rows on top of what is declared (reported per file; left out where the "
         "data do not determine it). Without it each sole is centred on its plate. The legs' base position, and so "
         "every base row's moment, rests on it: an unmeasured common 1 cm moves the identified CoM by 1 cm; a "
         "difference between the feet cancels (docs/identification.md \"Where the soles stand\"). The declared "
         "placement is the same for every file read")
      ->type_name("SPEC");
}

}  // namespace exoid::cli
