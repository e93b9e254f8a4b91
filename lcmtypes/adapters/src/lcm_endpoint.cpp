#include <exoid/lcm/lcm_endpoint.hpp>

#include <exoid/lcm/channels.hpp>
#include <lcm/lcm.h>

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace exoid {

namespace {

const char* const kProviders[] = {"udpm", "memq", "file"};

}  // namespace

std::string LcmEndpoint::defaultUrl() {
  const char* env = std::getenv("LCM_DEFAULT_URL");
  if (env != nullptr && env[0] != '\0') return env;
  return channels::kDefaultUrl;
}

bool LcmEndpoint::checkUrl(const std::string& url, std::string* normalised, std::string* why) {
  auto refuse = [&](const std::string& text) {
    if (why) *why = "LCM URL '" + url + "': " + text;
    return false;
  };
  const size_t sep = url.find("://");
  if (sep == std::string::npos || sep == 0)
    return refuse("expected provider://..., e.g. " + std::string(channels::kDefaultUrl) + " or memq://");
  const std::string provider = url.substr(0, sep);
  if (std::find(std::begin(kProviders), std::end(kProviders), provider) == std::end(kProviders))
    return refuse("provider '" + provider + "' is not allowed (use udpm, memq or file)");

  std::string out = url;
  if (provider == "udpm") {
    const size_t q = url.find('?');
    const std::string address = url.substr(sep + 3, q == std::string::npos ? std::string::npos : q - sep - 3);
    if (address.empty() || address.find(':') == std::string::npos)
      return refuse("udpm needs a multicast group and port, e.g. " + std::string(channels::kDefaultUrl));
    bool has_ttl = false;
    if (q != std::string::npos) {
      const std::string query = url.substr(q + 1);
      size_t start = 0;
      while (start <= query.size()) {
        size_t end = query.find('&', start);
        if (end == std::string::npos) end = query.size();
        const std::string option = query.substr(start, end - start);
        if (option.compare(0, 4, "ttl=") == 0) {
          const std::string value = option.substr(4);
          if (value != "0")
            return refuse("ttl=" + value + " refused: exoid only uses ttl=0 so messages never leave this host");
          has_ttl = true;
        } else if (option == "ttl") {
          return refuse("ttl needs a value (ttl=0)");
        }
        start = end + 1;
      }
    }
    if (!has_ttl) out += (q == std::string::npos ? "?" : (url.back() == '?' || url.back() == '&' ? "" : "&")) +
                         std::string("ttl=0");
  }
  if (normalised) *normalised = out;
  return true;
}

lcm_t* LcmEndpoint::open(const std::string& url, std::string* normalised, std::string* why) {
  if (!checkUrl(url, normalised, why)) return nullptr;
  lcm_t* lcm = lcm_create(normalised->c_str());
  if (lcm == nullptr && why) {
    *why = "lcm_create('" + *normalised + "') failed";
    if (normalised->compare(0, 4, "udpm") == 0)
      *why += " (no multicast route? see docs/lcm.md: ip route add 224.0.0.0/4 dev lo)";
  }
  return lcm;
}

LcmEndpoint::LcmEndpoint(const std::string& url, size_t publish_buffer_bytes) {
  std::string why;
  lcm_ = open(url, &url_, &why);
  if (lcm_ == nullptr) throw std::runtime_error(why);
  buffer_.resize(std::max<size_t>(publish_buffer_bytes, 1));
}

LcmEndpoint::LcmEndpoint(Adopt, lcm_t* lcm, std::string url, size_t publish_buffer_bytes)
    : lcm_(lcm), url_(std::move(url)) {
  buffer_.resize(std::max<size_t>(publish_buffer_bytes, 1));
}

std::unique_ptr<LcmEndpoint> LcmEndpoint::create(const std::string& url, std::string* why,
                                                 size_t publish_buffer_bytes) {
  std::string normalised;
  lcm_t* lcm = open(url, &normalised, why);
  if (lcm == nullptr) return nullptr;
  return std::unique_ptr<LcmEndpoint>(new LcmEndpoint(Adopt{}, lcm, std::move(normalised), publish_buffer_bytes));
}

LcmEndpoint::~LcmEndpoint() {
  if (lcm_ == nullptr) return;
  for (auto& s : subs_) lcm_unsubscribe(lcm_, s->sub);
  lcm_destroy(lcm_);
}

int LcmEndpoint::fileno() const { return lcm_get_fileno(lcm_); }

void LcmEndpoint::reserve(size_t bytes) {
  if (bytes > buffer_.size()) buffer_.resize(bytes);
}

bool LcmEndpoint::fail(std::string* why, const char* text) {
  if (why) *why = text;
  return false;
}

bool LcmEndpoint::publishRaw(const char* channel, const void* data, size_t size, std::string* why) {
  if (channel == nullptr || channel[0] == '\0') return fail(why, "publish: empty channel name");
  if (size > static_cast<size_t>(UINT32_MAX)) return fail(why, "publish: message too large");
  if (lcm_publish(lcm_, channel, data, static_cast<unsigned int>(size)) != 0) {
    if (why) *why = std::string("publish on ") + channel + " failed (lcm_publish)";
    return false;
  }
  return true;
}

void LcmEndpoint::dispatch(const lcm_recv_buf_t* rbuf, const char* channel, void* user) {
  auto* s = static_cast<Subscription*>(user);
  s->handler(channel, rbuf->data, static_cast<int>(rbuf->data_size), rbuf->recv_utime);
}

int LcmEndpoint::subscribeRaw(const std::string& channel, RawHandler handler) {
  if (channel.empty()) throw std::runtime_error("LcmEndpoint::subscribe: empty channel");
  if (!handler) throw std::runtime_error("LcmEndpoint::subscribe(" + channel + "): empty handler");
  auto s = std::make_unique<Subscription>();
  s->id = next_id_++;
  s->handler = std::move(handler);
  s->sub = lcm_subscribe(lcm_, channel.c_str(), &LcmEndpoint::dispatch, s.get());
  if (s->sub == nullptr) throw std::runtime_error("LcmEndpoint::subscribe(" + channel + "): lcm_subscribe failed");
  const int id = s->id;
  subs_.push_back(std::move(s));
  return id;
}

bool LcmEndpoint::unsubscribe(int id) {
  for (auto it = subs_.begin(); it != subs_.end(); ++it) {
    if ((*it)->id == id) {
      lcm_unsubscribe(lcm_, (*it)->sub);
      subs_.erase(it);
      return true;
    }
  }
  return false;
}

int LcmEndpoint::handleTimeout(int timeout_ms, std::string* why) {
  if (timeout_ms < 0) {
    fail(why, "handleTimeout: negative timeout (exoid never waits forever)");
    return -1;
  }
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  pollfd pfd{};
  pfd.fd = lcm_get_fileno(lcm_);
  pfd.events = POLLIN;
  int remaining = timeout_ms;
  for (;;) {
    pfd.revents = 0;
    const int rc = ::poll(&pfd, 1, remaining);
    if (rc > 0) break;
    if (rc == 0) return 0;
    if (errno != EINTR) {
      if (why) *why = std::string("handleTimeout: poll failed: ") + std::strerror(errno);
      return -1;
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (left <= 0) return 0;
    remaining = static_cast<int>(left);
  }
  if ((pfd.revents & POLLIN) == 0) {
    fail(why, "handleTimeout: LCM file descriptor reported an error");
    return -1;
  }
  if (lcm_handle(lcm_) != 0) {
    fail(why, "handleTimeout: lcm_handle failed");
    return -1;
  }
  return 1;
}

int LcmEndpoint::handleAvailable(int max_messages, std::string* why) {
  int handled = 0;
  while (handled < max_messages) {
    const int rc = handleTimeout(0, why);
    if (rc < 0) return -1;
    if (rc == 0) break;
    ++handled;
  }
  return handled;
}

}  // namespace exoid
