// The diagnosis's sidecar (estimator::readEffects, `effects.yaml`: what `exoid identify --effects` and `exo_estimator
// --effects` read). Properties: a rejection is one line naming the file; an accepted set holds only what its consumers
// can use (known joints, finite values, the kind's own keys: a positive tanh width on dry friction only, a finite
// center on the elastic kinds, a nonzero scale on elastic_exp and elastic_exp_coupled, another joint's angle on the
// coupled kinds, a finite ratio and neighbour's center on elastic_exp_coupled only, positive shape constants); written back by writeEffects it reads back to the same set, value for value.
#include <unistd.h>

#include <cmath>
#include <string>

#include "exoid/estimator/diagnose.hpp"
#include "exoid/model/urdf.hpp"
#include "fuzz_support.hpp"

namespace {
const exoid::Model& exo() {
  static const exoid::Model model = [] {
    exoid::Model m;
    std::string error;
    if (!exoid::buildModelFromUrdfFile(std::string(EXOID_CONFIG_DIR) + "/exo.urdf", true, m, &error)) std::abort();
    return m;
  }();
  return model;
}

bool sameEffect(const exoid::estimator::Effect& a, const exoid::estimator::Effect& b) {
  return a.kind == b.kind && a.joint == b.joint && a.value == b.value && a.width == b.width && a.center == b.center &&
         a.coupled == b.coupled && a.ratio == b.ratio && a.coupled_center == b.coupled_center;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace exoid::estimator;
  static exoid::fuzz::MemFile file;
  const std::string& path = file.write(data, size);
  const exoid::Model& model = exo();
  EffectSet set;
  std::string error;
  if (!readEffects(path, model, set, &error)) {
    exoid::fuzz::checkOneLine(error, "a rejected sidecar gets a one-line error");
    EXOID_FUZZ_CHECK(error.rfind(path, 0) == 0, "the error names the file");
    return 0;
  }
  EXOID_FUZZ_CHECK(set.shape.coulomb_width > 0 && std::isfinite(set.shape.coulomb_width), "positive Coulomb width");
  EXOID_FUZZ_CHECK(set.shape.stribeck_velocity > 0 && std::isfinite(set.shape.stribeck_velocity), "positive Stribeck velocity");
  for (const Effect& e : set.effects) {
    EXOID_FUZZ_CHECK(e.joint >= 0 && e.joint < model.njoints, "a known joint");
    EXOID_FUZZ_CHECK(std::isfinite(e.value), "a finite value");
    EXOID_FUZZ_CHECK(std::isfinite(e.width) && std::isfinite(e.center), "finite shape values");
    if (isDryFriction(e.kind)) EXOID_FUZZ_CHECK(e.width >= 0.0, "a dry-friction width is positive (or the set's)");
    const bool exponential = e.kind == EffectKind::ElasticExp || e.kind == EffectKind::ElasticExpCoupled;
    if (exponential) EXOID_FUZZ_CHECK(e.width != 0.0, "an exponential spring has its scale");
    if (!isDryFriction(e.kind) && !exponential) EXOID_FUZZ_CHECK(e.width == 0.0, "no stray width");
    if (!isElastic(e.kind)) EXOID_FUZZ_CHECK(e.center == 0.0, "no stray center");
    if (isCoupled(e.kind))
      EXOID_FUZZ_CHECK(e.coupled >= 0 && e.coupled < model.njoints && e.coupled != e.joint, "another joint's angle");
    else
      EXOID_FUZZ_CHECK(e.coupled == -1, "no stray angle_of");
    if (e.kind == EffectKind::ElasticExpCoupled)
      EXOID_FUZZ_CHECK(std::isfinite(e.ratio) && std::isfinite(e.coupled_center), "a finite ratio and neighbour's center");
    else
      EXOID_FUZZ_CHECK(e.ratio == 0.0 && e.coupled_center == 0.0, "no stray ratio or angle_of_center");
  }
  // Written back, read back: the same set.
  static const std::string out = "/tmp/exoid_fuzz_effects_" + std::to_string(::getpid()) + ".yaml";
  EXOID_FUZZ_CHECK(writeEffects(out, model, set, &error), "an accepted set can be written");
  EffectSet back;
  EXOID_FUZZ_CHECK(readEffects(out, model, back, &error), "what writeEffects writes reads back");
  EXOID_FUZZ_CHECK(back.effects.size() == set.effects.size(), "the same number of effects");
  for (size_t i = 0; i < set.effects.size(); ++i) EXOID_FUZZ_CHECK(sameEffect(back.effects[i], set.effects[i]), "the same effects");
  EXOID_FUZZ_CHECK(back.shape.coulomb_width == set.shape.coulomb_width &&
                       back.shape.stribeck_velocity == set.shape.stribeck_velocity,
                   "the same shape constants");
  EXOID_FUZZ_CHECK(back.model == set.model, "the same model name");
  EXOID_FUZZ_CHECK(back.base_body_moves == set.base_body_moves, "the same base_body_moves");
  return 0;
}
