#pragma once
// The clinic's prior of an exoskeleton with its wearer (`exoid model wearer`, docs/wearer.md): the exoskeleton URDF
// plus the wearer's segments, from de Leva's table at the typed mass and height, as links on fixed joints to the exo
// links they ride on (the whole upper body rigid on the pelvis). exoid's URDF loader lumps fixed links into their
// parent, so the controller and the estimator see exo + wearer per link; the segments stay readable by name.
#include <string>

#include "exoid/model/model.hpp"
#include "exoid/model/wearer_mount.hpp"

namespace exoid::tools {

/// The exo links the wearer rides on, in the model's standing pose (q = 0, base at the origin). False with *err
/// when a link ("body", "<side>_thigh", "_shank", "_ankle", "_foot") or sole frame ("<side>_sole") is missing.
bool exoStandingFromModel(const Model& exo, ExoStanding& out, std::string* err);

/// Copies `urdf_in` with one `<link name="wearer_<segment>">` (wearerFrameName, model/wearer_mount.hpp; its inertial
/// in the carrying link's frame) and one fixed `<joint name="wearer_<segment>_mount">` per mounted segment, inserted
/// before `</robot>`. Atomic write.
/// False with *err on an unreadable input, a URDF without `</robot>`, or an unwritable output.
bool writeWearerUrdf(const std::string& urdf_in, const WearerMount& mount, const std::string& urdf_out,
                     std::string* err);

/// The whole of `exoid model wearer`: loads the exo URDF (floating base), builds the wearer from `spec`, mounts it
/// and writes the prior. *mount (optional) receives the placed segments. False with *err on any failure.
bool writeWearerPrior(const std::string& exo_urdf, const WearerSpec& spec, const std::string& urdf_out,
                      WearerMount* mount, std::string* err);

}  // namespace exoid::tools
