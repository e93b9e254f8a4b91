#include <exoid/lcm/message_gate.hpp>
#include <exoid/tick_order.hpp>

#include <cstring>
#include <stdexcept>

namespace exoid {

MessageGate::MessageGate(std::vector<std::string> channels) {
  channels_.reserve(channels.size());
  for (auto& name : channels) {
    if (name.empty()) throw std::invalid_argument("MessageGate: empty channel name");
    for (const auto& c : channels_)
      if (c.name == name) throw std::invalid_argument("MessageGate: channel '" + name + "' listed twice");
    Channel c;
    c.name = std::move(name);
    channels_.push_back(std::move(c));
  }
}

int MessageGate::channelIndex(const char* channel) const {
  if (channel == nullptr) return -1;
  for (size_t i = 0; i < channels_.size(); ++i)
    if (std::strcmp(channels_[i].name.c_str(), channel) == 0) return static_cast<int>(i);
  return -1;
}

const MessageGate::Channel& MessageGate::at(int channel) const {
  if (channel < 0 || channel >= static_cast<int>(channels_.size()))
    throw std::out_of_range("MessageGate: channel index " + std::to_string(channel) + " out of range [0, " +
                            std::to_string(channels_.size()) + ")");
  return channels_[static_cast<size_t>(channel)];
}
MessageGate::Channel& MessageGate::at(int channel) {
  return const_cast<Channel&>(static_cast<const MessageGate*>(this)->at(channel));
}

bool MessageGate::inOrder(int channel, int64_t tick, RejectReason* reason, std::string* why) const {
  const Channel& c = at(channel);
  const TickOrder order = tickOrder(c.has_tick, c.last_tick, tick);
  if (order == TickOrder::Newer) return true;
  const bool duplicate = order == TickOrder::Duplicate;
  if (reason) *reason = duplicate ? RejectReason::Duplicate : RejectReason::OutOfOrder;
  if (why)
    *why = c.name + ": tick " + std::to_string(tick) + (duplicate ? " repeats" : " is older than") +
           " the last accepted tick " + std::to_string(c.last_tick);
  return false;
}

void MessageGate::commit(int channel, int64_t tick) {
  Channel& c = at(channel);
  if (c.has_tick && tick > c.last_tick + 1) c.skipped += static_cast<uint64_t>(tick - c.last_tick - 1);
  c.has_tick = true;
  c.last_tick = tick;
  ++c.accepted;
}

void MessageGate::reject(int channel, RejectReason reason) {
  const auto r = static_cast<size_t>(reason);
  if (r >= static_cast<size_t>(kNumRejectReasons))
    throw std::invalid_argument("MessageGate: invalid reject reason " + std::to_string(r));
  ++at(channel).rejected[r];
}

uint64_t MessageGate::accepted(int channel) const { return at(channel).accepted; }
uint64_t MessageGate::rejected(int channel, RejectReason reason) const {
  return at(channel).rejected.at(static_cast<size_t>(reason));
}
uint64_t MessageGate::rejected(int channel) const {
  uint64_t sum = 0;
  for (uint64_t n : at(channel).rejected) sum += n;
  return sum;
}
uint64_t MessageGate::rejected(RejectReason reason) const {
  uint64_t sum = 0;
  for (const auto& c : channels_) sum += c.rejected.at(static_cast<size_t>(reason));
  return sum;
}
uint64_t MessageGate::rejectedTotal() const {
  uint64_t sum = 0;
  for (const auto& c : channels_)
    for (uint64_t n : c.rejected) sum += n;
  return sum;
}
uint64_t MessageGate::skipped(int channel) const { return at(channel).skipped; }
bool MessageGate::lastTick(int channel, int64_t* tick) const {
  const Channel& c = at(channel);
  if (c.has_tick && tick) *tick = c.last_tick;
  return c.has_tick;
}
void MessageGate::reset() {
  for (auto& c : channels_) {
    c.has_tick = false;
    c.last_tick = 0;
    c.accepted = 0;
    c.skipped = 0;
    c.rejected.fill(0);
  }
}

}  // namespace exoid
