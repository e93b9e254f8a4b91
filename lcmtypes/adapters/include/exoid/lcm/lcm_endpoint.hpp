#pragma once
// LcmEndpoint: a thin owner of an lcm_t (LCM's C API) for exoid's processes and tests.
//  - URL: explicit, else $LCM_DEFAULT_URL, else channels::kDefaultUrl (udpm, ttl=0). A udpm URL must have
//    ttl=0 (added when absent); any other ttl is refused. Providers: udpm, memq (in-process, for tests),
//    file (log playback).
//  - publish(): encodes into a buffer owned by the endpoint (sized at construction / reserve(), grown only
//    when a message is larger), then lcm_publish. No allocation once the buffer is large enough.
//  - subscribe(): raw bytes or decoded messages, via callbacks invoked from handle*() on the calling thread.
//  - handleTimeout(ms): poll(lcm_get_fileno) with a bound, so a caller never blocks forever.
// Not thread-safe: use one endpoint per thread (LCM itself is thread-safe, this wrapper's buffers are not).
#include <exoid/lcm/safe_decode.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

typedef struct _lcm_t lcm_t;
typedef struct _lcm_subscription_t lcm_subscription_t;
typedef struct _lcm_recv_buf_t lcm_recv_buf_t;

namespace exoid {

class LcmEndpoint {
 public:
  /// channel, encoded bytes, byte count, receive time (microseconds since the epoch).
  using RawHandler = std::function<void(const char* channel, const void* data, int size, int64_t recv_utime)>;

  /// $LCM_DEFAULT_URL if set and non-empty, else channels::kDefaultUrl.
  static std::string defaultUrl();
  /// Validates `url`; on success writes the URL to use (ttl=0 appended to a udpm URL without ttl) to
  /// *normalised. On failure returns false with a one-line reason. Never throws.
  static bool checkUrl(const std::string& url, std::string* normalised, std::string* why);

  /// Throws std::runtime_error (one line) if the URL is refused or lcm_create fails.
  explicit LcmEndpoint(const std::string& url = defaultUrl(), size_t publish_buffer_bytes = 64 * 1024);
  /// Non-throwing factory: nullptr and *why on failure.
  static std::unique_ptr<LcmEndpoint> create(const std::string& url, std::string* why,
                                             size_t publish_buffer_bytes = 64 * 1024);
  ~LcmEndpoint();
  LcmEndpoint(const LcmEndpoint&) = delete;
  LcmEndpoint& operator=(const LcmEndpoint&) = delete;

  const std::string& url() const { return url_; }
  /// File descriptor that becomes readable when a message is waiting (for callers' own poll loops).
  int fileno() const;
  lcm_t* raw() const { return lcm_; }

  /// Makes the publish buffer at least `bytes` long (call on setup, outside loops).
  void reserve(size_t bytes);
  size_t bufferSize() const { return buffer_.size(); }

  /// Encodes `msg` (an lcm-gen C++ type) into the endpoint's buffer and publishes it on `channel`.
  template <class Msg>
  bool publish(const char* channel, const Msg& msg, std::string* why = nullptr) {
    const int size = msg.getEncodedSize();
    if (size <= 0) return fail(why, "publish: message has no encoded size");
    if (static_cast<size_t>(size) > buffer_.size()) buffer_.resize(static_cast<size_t>(size));  // rare growth
    const int n = msg.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
    if (n < 0) return fail(why, "publish: encoding failed (inconsistent array sizes?)");
    return publishRaw(channel, buffer_.data(), static_cast<size_t>(n), why);
  }
  /// Publishes already encoded bytes.
  bool publishRaw(const char* channel, const void* data, size_t size, std::string* why = nullptr);

  /// Subscribes to `channel` (LCM treats it as a regular expression). Returns a subscription id (> 0).
  /// Throws std::runtime_error if LCM refuses (setup-time call).
  int subscribeRaw(const std::string& channel, RawHandler handler);
  /// Decodes (safeDecode) into one Msg kept per subscription (reused, so steady-state decoding does not
  /// reallocate) and calls on_msg; bytes that are not a well-formed Msg go to on_malformed (if given).
  template <class Msg>
  int subscribe(const std::string& channel, std::function<void(const char* channel, const Msg& msg)> on_msg,
                std::function<void(const char* channel, int size)> on_malformed = {}) {
    auto scratch = std::make_shared<Msg>();
    return subscribeRaw(channel, [scratch, on_msg = std::move(on_msg), on_malformed = std::move(on_malformed)](
                                     const char* ch, const void* data, int size, int64_t) {
      if (!safeDecode(data, size, *scratch)) {
        if (on_malformed) on_malformed(ch, size);
        return;
      }
      on_msg(ch, *scratch);
    });
  }
  bool unsubscribe(int id);

  /// Waits at most timeout_ms (>= 0) for one message and dispatches it. Returns 1 if a message was handled,
  /// 0 on timeout, -1 on error (reason in *why). Never waits longer than timeout_ms (EINTR resumes polling
  /// for the remaining time only).
  int handleTimeout(int timeout_ms, std::string* why = nullptr);
  /// Dispatches every message already waiting, without blocking, up to max_messages. Returns how many, or
  /// -1 on error.
  int handleAvailable(int max_messages = 1000, std::string* why = nullptr);

 private:
  struct Subscription {
    int id = 0;
    lcm_subscription_t* sub = nullptr;
    RawHandler handler;
  };
  struct Adopt {};
  LcmEndpoint(Adopt, lcm_t* lcm, std::string url, size_t publish_buffer_bytes);
  static lcm_t* open(const std::string& url, std::string* normalised, std::string* why);
  static bool fail(std::string* why, const char* text);
  static void dispatch(const lcm_recv_buf_t* rbuf, const char* channel, void* user);

  lcm_t* lcm_ = nullptr;
  std::string url_;
  std::vector<uint8_t> buffer_;
  std::vector<std::unique_ptr<Subscription>> subs_;
  int next_id_ = 1;
};

}  // namespace exoid
