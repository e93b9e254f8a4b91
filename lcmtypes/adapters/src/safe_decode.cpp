#include <exoid/lcm/safe_decode.hpp>

#include <cstdint>

namespace exoid {

namespace {

// Walks an LCM encoding (big-endian) without allocating; any step past the end makes ok() false.
class Walker {
 public:
  Walker(const void* data, int size) : p_(static_cast<const uint8_t*>(data)), size_(size), ok_(data && size > 0) {}

  bool ok() const { return ok_; }
  bool complete() const { return ok_ && pos_ == size_; }

  void skip(int64_t bytes) {
    if (!ok_ || bytes < 0 || bytes > size_ - pos_) {
      ok_ = false;
      return;
    }
    pos_ += static_cast<int>(bytes);
  }
  void skipDoubles(int64_t n) { skip(n * 8); }

  int32_t readCount() {
    if (!ok_ || size_ - pos_ < 4) {
      ok_ = false;
      return 0;
    }
    const uint32_t v = (uint32_t{p_[pos_]} << 24) | (uint32_t{p_[pos_ + 1]} << 16) | (uint32_t{p_[pos_ + 2]} << 8) |
                       uint32_t{p_[pos_ + 3]};
    pos_ += 4;
    const auto n = static_cast<int32_t>(v);
    if (n < 0 || n > size_ - pos_) ok_ = false;  // every element takes at least one byte
    return ok_ ? n : 0;
  }

  // LCM string: int32 length including the terminating NUL, then the bytes.
  void skipString() {
    const int32_t len = readCount();
    if (!ok_) return;
    if (len < 1 || p_[pos_ + len - 1] != '\0') {
      ok_ = false;
      return;
    }
    skip(len);
  }
  void skipStrings(int32_t n) {
    for (int32_t i = 0; i < n && ok_; ++i) skipString();
  }

 private:
  const uint8_t* p_;
  int size_;
  int pos_ = 0;
  bool ok_;
};

template <class Msg>
bool decodeChecked(const Walker& w, const void* data, int size, Msg& msg) {
  if (!w.complete()) return false;
  try {
    return msg.decode(data, 0, size) == size;
  } catch (const std::exception&) {
    return false;
  }
}

constexpr int kHash = 8;

}  // namespace

// The layouts below mirror lcmtypes/*.lcm field by field (tests/lcmtypes check every type round-trips
// through safeDecode, so a field added to a .lcm without updating its walker fails the tests).

bool safeDecode(const void* data, int size, exoid_lcm::robot_state_t& msg) {
  Walker w(data, size);
  w.skip(kHash + 8 + 8);  // utime, tick
  const int32_t n = w.readCount();
  w.skipStrings(n);
  w.skipDoubles(2 * int64_t{n});  // q, tau
  w.skip(n);                      // has_tau
  w.skipDoubles(4 + 3 + 3);
  return decodeChecked(w, data, size, msg);
}

bool safeDecode(const void* data, int size, exoid_lcm::force_plate_t& msg) {
  Walker w(data, size);
  w.skip(kHash + 8 + 8);
  w.skipString();
  w.skipDoubles(3 + 3 + 3 + 3 + 4);
  return decodeChecked(w, data, size, msg);
}

bool safeDecode(const void* data, int size, exoid_lcm::joint_command_t& msg) {
  Walker w(data, size);
  w.skip(kHash + 8 + 8 + 8 + 1);  // utime, tick, source_tick, mode
  const int32_t n = w.readCount();
  w.skipStrings(n);
  w.skipDoubles(2 * int64_t{n});
  return decodeChecked(w, data, size, msg);
}

bool safeDecode(const void* data, int size, exoid_lcm::controller_status_t& msg) {
  Walker w(data, size);
  w.skip(kHash + 8 + 8 + 1 + 4);  // utime, tick, qp_status, qp_iterations
  w.skipDoubles(2);
  w.skip(4 + 4);
  w.skipDoubles(3 * 4 + 6 * 4);
  w.skip(4 * 3);
  return decodeChecked(w, data, size, msg);
}

bool safeDecode(const void* data, int size, exoid_lcm::estimator_output_t& msg) {
  Walker w(data, size);
  // utime, tick, valid, consistent, samples_used, samples_rejected, the three reasons, samples_missing,
  // excitation, effective_samples
  w.skip(kHash + 8 + 8 + 1 + 1 + 8 + 4 + 4 + 4 + 4 + 8 + 8 + 8);
  const int32_t np = w.readCount();
  w.skipStrings(np);
  w.skipDoubles(2 * int64_t{np});
  const int32_t nb = w.readCount();
  w.skipDoubles(2 * int64_t{nb});
  const int32_t nc = w.readCount();
  w.skipStrings(nc);
  w.skipDoubles(2 * int64_t{nc});
  w.skipDoubles(3 + 1 + int64_t{nc});  // com_stddev, mass_stddev, tau_correction_stddev
  return decodeChecked(w, data, size, msg);
}

bool safeDecode(const void* data, int size, exoid_lcm::ground_truth_t& msg) {
  Walker w(data, size);
  w.skip(kHash + 8 + 8);
  w.skipDoubles(3 + 4 + 3 + 3 + 3 + 3);
  const int32_t n = w.readCount();
  w.skipStrings(n);
  w.skipDoubles(4 * int64_t{n});
  w.skipDoubles(3 * 4 + 3);  // foot wrenches, com
  w.skip(1);                 // has_trunk (an LCM boolean is one byte)
  w.skipDoubles(3 * 3);      // trunk_angle, trunk_rate, trunk_com
  return decodeChecked(w, data, size, msg);
}

}  // namespace exoid
