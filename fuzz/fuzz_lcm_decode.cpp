// Decoding of untrusted LCM bytes: safeDecode, then the adapters (fromLcm) against the exoskeleton's joint
// and parameter names. The first input byte picks the message type, the rest is the encoded message.
// Properties: safeDecode accepts only complete messages (encoded size = bytes received); whatever fromLcm
// accepts, toLcm writes back into a message that safeDecode and fromLcm accept again.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "exoid/estimator/base_parameters.hpp"
#include "exoid/lcm/adapters.hpp"
#include "exoid/lcm/safe_decode.hpp"
#include "exoid/model/urdf.hpp"
#include "fuzz_support.hpp"

namespace {

std::vector<std::string> g_joints, g_params, g_coords;
size_t g_num_base = 0;

template <class Msg>
std::vector<uint8_t> encode(const Msg& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  EXOID_FUZZ_CHECK(msg.encode(bytes.data(), 0, static_cast<int>(bytes.size())) == static_cast<int>(bytes.size()),
                   "a message encodes into its encoded size");
  return bytes;
}

// decode -> adapt -> (accepted) write back -> decode -> adapt again.
template <class Msg, class Sample, class From, class To>
void roundTrip(const uint8_t* data, int size, From from, To to) {
  Msg msg;
  if (!exoid::safeDecode(data, size, msg)) return;
  EXOID_FUZZ_CHECK(msg.getEncodedSize() == size, "safeDecode accepts exactly one whole message");
  Sample sample;
  std::string why;
  exoid::RejectReason reason{};
  if (!from(msg, sample, &why, &reason)) {
    exoid::fuzz::checkOneLine(why, "a rejection has a one-line reason");
    EXOID_FUZZ_CHECK(static_cast<int>(reason) < exoid::kNumRejectReasons, "a rejection has a valid reason");
    return;
  }
  Msg again;
  to(sample, again);
  const std::vector<uint8_t> bytes = encode(again);
  Msg decoded;
  EXOID_FUZZ_CHECK(exoid::safeDecode(bytes.data(), static_cast<int>(bytes.size()), decoded),
                   "a message written from an accepted sample decodes");
  Sample sample2;
  EXOID_FUZZ_CHECK(from(decoded, sample2, &why, &reason), "an accepted sample written back is accepted again");
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  exoid::Model model;
  std::string error;
  if (!exoid::buildModelFromUrdfFile(EXOID_CONFIG_DIR "/exo.urdf", true, model, &error)) {
    std::fprintf(stderr, "fuzz_lcm_decode: %s\n", error.c_str());
    std::abort();
  }
  g_joints = model.joint_names;
  g_params = model.paramNames();
  g_coords = model.coordinateNames();
  g_num_base = exoid::computeBaseParameters(model).independent.size();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1 || size > (1u << 20)) return 0;
  const uint8_t* msg = data + 1;
  const int n = static_cast<int>(size - 1);
  using namespace exoid;
  switch (data[0] % 6) {
    case 0:
      roundTrip<exoid_lcm::robot_state_t, RobotStateSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, g_joints, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, g_joints, m); });
      break;
    case 1:
      roundTrip<exoid_lcm::force_plate_t, ForcePlateSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, -1, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, m); });
      break;
    case 2:
      roundTrip<exoid_lcm::joint_command_t, JointCommandSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, g_joints, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, g_joints, m); });
      break;
    case 3:
      roundTrip<exoid_lcm::controller_status_t, ControllerStatusSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, m); });
      break;
    case 4:
      roundTrip<exoid_lcm::estimator_output_t, EstimatorOutputSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, g_params, g_num_base, g_coords, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, g_params, g_coords, m); });
      break;
    case 5:
      roundTrip<exoid_lcm::ground_truth_t, GroundTruthSample>(
          msg, n, [](auto& m, auto& s, auto* w, auto* r) { return fromLcm(m, g_joints, s, w, r); },
          [](auto& s, auto& m) { toLcm(s, g_joints, m); });
      break;
  }
  return 0;
}
