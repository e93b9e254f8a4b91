#pragma once
// Decoding of untrusted bytes. LCM's generated decode() sizes its vectors from the count fields BEFORE it
// checks the buffer length, and a string length of 0 or < 0 makes it throw std::length_error: a hostile or
// corrupted message could make a receiver allocate gigabytes or terminate. safeDecode first walks the
// encoding (every count and string length must fit in the bytes received, the total must match exactly),
// then decodes, and never throws. Use it (or MessageGate::admitEncoded, LcmEndpoint::subscribe, which do)
// for everything that comes off the wire.
#include <exoid_lcm/controller_status_t.hpp>
#include <exoid_lcm/estimator_output_t.hpp>
#include <exoid_lcm/force_plate_t.hpp>
#include <exoid_lcm/ground_truth_t.hpp>
#include <exoid_lcm/joint_command_t.hpp>
#include <exoid_lcm/robot_state_t.hpp>

#include <exception>

namespace exoid {

/// exoid's types: the layout is checked before decoding. False (msg unspecified) if the bytes are not one
/// complete, well-formed message of that type.
bool safeDecode(const void* data, int size, exoid_lcm::robot_state_t& msg);
bool safeDecode(const void* data, int size, exoid_lcm::force_plate_t& msg);
bool safeDecode(const void* data, int size, exoid_lcm::joint_command_t& msg);
bool safeDecode(const void* data, int size, exoid_lcm::controller_status_t& msg);
bool safeDecode(const void* data, int size, exoid_lcm::estimator_output_t& msg);
bool safeDecode(const void* data, int size, exoid_lcm::ground_truth_t& msg);

/// Any other lcm-gen type: LCM's decode, exceptions turned into false (no layout check).
template <class Msg>
bool safeDecode(const void* data, int size, Msg& msg) {
  if (data == nullptr || size <= 0) return false;
  try {
    return msg.decode(data, 0, size) >= 0;
  } catch (const std::exception&) {
    return false;
  }
}

}  // namespace exoid
