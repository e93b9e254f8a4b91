#pragma once
// MessageGate: input hygiene for the LCM receivers (sim, controller, estimator).
//
// Per channel it remembers the last ACCEPTED tick and rejects (and counts, per channel and per reason):
//   Duplicate   tick == last accepted tick
//   OutOfOrder  tick <  last accepted tick
//   NonFinite / Malformed   as reported by the adapter (fromLcm) or an undecodable buffer.
// A message is accepted only if it is in order AND its adapter accepts it; only then is its tick recorded,
// so a rejected message never advances the channel. Ticks may skip (the gap is counted, not rejected).
// Each rejection increments exactly one counter by one. Channels are fixed at construction (no allocation
// afterwards); the gate is not thread-safe (use it from the thread that handles the LCM endpoint).
#include <exoid/lcm/adapters.hpp>
#include <exoid/lcm/safe_decode.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace exoid {

class MessageGate {
 public:
  /// Throws std::invalid_argument on an empty or duplicate channel name.
  explicit MessageGate(std::vector<std::string> channels);

  /// Index of `channel`, or -1 if the gate does not know it. Does not allocate.
  int channelIndex(const char* channel) const;
  int numChannels() const { return static_cast<int>(channels_.size()); }
  const std::string& channelName(int channel) const { return channels_.at(static_cast<size_t>(channel)).name; }

  /// Ordering check only (no side effect): true if `tick` is newer than the channel's last accepted tick;
  /// otherwise sets *reason (Duplicate or OutOfOrder) and *why.
  bool inOrder(int channel, int64_t tick, RejectReason* reason = nullptr, std::string* why = nullptr) const;
  /// Records an accepted message's tick (counts it, and any skipped ticks).
  void commit(int channel, int64_t tick);
  /// Counts one rejection on `channel`.
  void reject(int channel, RejectReason reason);

  /// Full check of a decoded message: order, then fromLcm(msg, expected..., out, why, reason); commits on
  /// success, counts exactly one rejection on failure. `out` is written only on success.
  template <class Msg, class Sample, class... Expected>
  bool admit(int channel, const Msg& msg, Sample& out, std::string* why, const Expected&... expected) {
    RejectReason reason = RejectReason::Malformed;
    if (!inOrder(channel, msg.tick, &reason, why) || !fromLcm(msg, expected..., out, why, &reason)) {
      reject(channel, reason);
      return false;
    }
    commit(channel, msg.tick);
    return true;
  }

  /// Same, from the raw bytes of an LCM message: `scratch` receives the decoded message (reuse it between
  /// calls); bytes that are not one well-formed Msg (wrong type/hash, truncated, impossible counts) count as
  /// Malformed. Decoding goes through safeDecode: never throws, never sizes anything from a bogus count.
  template <class Msg, class Sample, class... Expected>
  bool admitEncoded(int channel, const void* data, int size, Msg& scratch, Sample& out, std::string* why,
                    const Expected&... expected) {
    if (!safeDecode(data, size, scratch)) {
      if (why) *why = std::string(Msg::getTypeName()) + ": " + std::to_string(size) + " bytes do not decode";
      reject(channel, RejectReason::Malformed);
      return false;
    }
    return admit(channel, scratch, out, why, expected...);
  }

  // --- counters ---
  uint64_t accepted(int channel) const;
  uint64_t rejected(int channel, RejectReason reason) const;
  uint64_t rejected(int channel) const;  ///< all reasons on one channel
  uint64_t rejected(RejectReason reason) const;  ///< one reason, all channels
  uint64_t rejectedTotal() const;
  /// Ticks skipped between consecutive accepted messages (e.g. 3 then 6 skips 2).
  uint64_t skipped(int channel) const;
  /// Last accepted tick; false if none yet.
  bool lastTick(int channel, int64_t* tick) const;
  /// Forgets ticks and zeroes every counter (e.g. on a simulation restart).
  void reset();

 private:
  struct Channel {
    std::string name;
    bool has_tick = false;
    int64_t last_tick = 0;
    uint64_t accepted = 0;
    uint64_t skipped = 0;
    std::array<uint64_t, kNumRejectReasons> rejected{};
  };
  const Channel& at(int channel) const;
  Channel& at(int channel);
  std::vector<Channel> channels_;
};

}  // namespace exoid
