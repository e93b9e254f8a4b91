// The tick assembly (tick_assembly.hpp): slots for the held ticks, kept oldest first.
#include "exoid/estimator/tick_assembly.hpp"

#include <algorithm>

#include "exoid/tick_order.hpp"

namespace exoid::estimator {

TickAssembly::TickAssembly(unsigned needed, long window, int capacity)
    : needed_(needed), window_(std::max(0L, window)) {
  const int n = std::max(1, capacity);
  slots_.resize(n);
  order_.resize(n);
  free_.resize(n);
  restart(-1, TickAssemblyCounts());
}

int TickAssembly::find(int64_t tick) const {
  for (int i = held_ - 1; i >= 0; --i)  // from the newest: a message is usually for a recent tick
    if (slots_[order_[i]].tick == tick) return order_[i];
  return -1;
}

TickPlacement TickAssembly::check(int channel, int64_t tick) const {
  if (channel < 0 || channel >= kTickChannels || tick < 0) return TickPlacement::OutOfOrder;
  const unsigned bit = 1u << channel;
  const int s = find(tick);
  if (s >= 0) return slots_[s].present & bit ? TickPlacement::Duplicate : TickPlacement::Accepted;
  // The channel's own order rule is MessageGate's (tick_order.hpp): its last tick again is a duplicate.
  if (tickOrder(last_[channel] >= 0, last_[channel], tick) == TickOrder::Duplicate) return TickPlacement::Duplicate;
  if (tick <= last_released_ || (newest_ >= 0 && tick < newest_ - window_)) return TickPlacement::OutOfOrder;
  return held_ == capacity() ? TickPlacement::Overflow : TickPlacement::Accepted;
}

TickPlacement TickAssembly::place(int channel, int64_t tick, int* slot) {
  const TickPlacement p = check(channel, tick);
  if (slot) *slot = -1;
  switch (p) {
    case TickPlacement::Duplicate: ++counts_.duplicates; return p;
    case TickPlacement::OutOfOrder: ++counts_.out_of_order; return p;
    case TickPlacement::Overflow: ++counts_.overflow; return p;
    case TickPlacement::Accepted: break;
  }
  int s = find(tick);
  if (s < 0) {  // a new tick: a free slot, inserted in tick order
    s = free_[--free_count_];
    slots_[s].tick = tick;
    slots_[s].present = 0;
    int i = held_++;
    for (; i > 0 && slots_[order_[i - 1]].tick > tick; --i) order_[i] = order_[i - 1];
    order_[i] = s;
  }
  slots_[s].present |= 1u << channel;
  last_[channel] = std::max(last_[channel], tick);
  newest_ = std::max(newest_, tick);
  ++counts_.accepted;
  if (slot) *slot = s;
  return p;
}

bool TickAssembly::release(ReleasedTick& out, bool flush) {
  if (held_ == 0) return false;
  const int s = order_[0];
  const Slot& oldest = slots_[s];
  const bool complete = (oldest.present & needed_) == needed_;
  if (!complete && !flush && newest_ - oldest.tick <= window_) return false;
  out.tick = oldest.tick;
  out.slot = s;
  out.present = oldest.present;
  out.complete = complete;
  ++(complete ? counts_.complete : counts_.incomplete);
  last_released_ = std::max(last_released_, oldest.tick);
  for (int i = 1; i < held_; ++i) order_[i - 1] = order_[i];
  --held_;
  free_[free_count_++] = s;
  return true;
}

void TickAssembly::restart(int64_t tick, const TickAssemblyCounts& counts) {
  const int64_t t = tick >= 0 ? tick : -1;
  held_ = 0;
  free_count_ = capacity();
  for (int i = 0; i < free_count_; ++i) free_[i] = free_count_ - 1 - i;
  newest_ = last_released_ = t;
  last_.fill(t);
  counts_ = counts;
}

}  // namespace exoid::estimator
