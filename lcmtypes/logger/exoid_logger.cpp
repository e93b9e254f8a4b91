// exoid_logger: records every LCM message on a udpm:// group into an lcm-logger format file, without loss.
// Debian's lcm-logger (LCM 1.3.1) drops bursts in its user-space receive ring when a lockstep simulation
// publishes ~30k messages/s (the kernel had delivered every datagram); this receiver reads the socket in
// batches (recvmmsg) straight into the event log, with a large kernel buffer, and drains it before exiting
// (lcmwire::UdpmReceiver, shared with exo_estimator).
#include <lcm/eventlog.h>
#include <netinet/in.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

#include "exoid/common/cli.hpp"
#include "exoid/common/strict_number.hpp"
#include "exoid/lcm/channels.hpp"
#include "lcm_wire.hpp"

namespace {

using exoid::channels::kDefaultUrl;

volatile sig_atomic_t g_stop = 0;
void onSignal(int) { g_stop = 1; }

int bad(const std::string& m) {
  std::fprintf(stderr, "exoid_logger: error: %s\n", m.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string url = std::getenv("LCM_DEFAULT_URL") ? std::getenv("LCM_DEFAULT_URL") : kDefaultUrl;
  std::string out;
  bool force = false, quiet = false;
  int64_t buf_mb = 64;
  CLI::App app{
      "Records every message published on an LCM udpm:// multicast group (all channels) into FILE in the\n"
      "lcm-logger event-log format (readable by lcm-logplayer, lcm-spy, exoid export). Runs until SIGINT or\n"
      "SIGTERM, then drains what the kernel still holds and prints per-channel counts. Small and fragmented LCM\n"
      "messages are both reassembled; malformed datagrams and messages with missing fragments are counted.",
      "exoid_logger"};
  exoid::common::configureCli(app);
  app.add_option("--lcm-url", url, "udpm://GROUP:PORT[?ttl=0...]; the default is $LCM_DEFAULT_URL when set")
      ->type_name("URL");
  app.add_option("--out", out, "event-log file to write")->required()->type_name("FILE");
  app.add_flag("--force", force, "overwrite FILE if it exists");
  app.add_option("--recv-buf-mb", buf_mb, "kernel receive buffer in MiB (as root it may exceed net.core.rmem_max)")
      ->transform(exoid::common::strictInteger(1, 1024))->type_name("N");
  app.add_flag("--quiet", quiet, "print only errors and the final summary");
  app.footer("exit codes: 0 success, 1 socket or file error, 2 bad input.");
  if (const int code = exoid::common::parseCli(app, argc, argv); code >= 0) return code;
  if (out.empty()) return bad("--out FILE is required");
  in_addr group{};
  uint16_t port = 0;
  std::string why, hostport;
  if (!exoid::lcmwire::parseUdpmUrl(url, &group, &port, &why, &hostport)) return bad("--lcm-url: " + why);
  if (!force && access(out.c_str(), F_OK) == 0) return bad("'" + out + "' exists (use --force to overwrite)");
  auto receiver = exoid::lcmwire::UdpmReceiver::open(url, static_cast<size_t>(buf_mb) << 20, &why);
  if (!receiver) {
    std::fprintf(stderr, "exoid_logger: error: %s\n", why.c_str());
    return 1;
  }
  lcm_eventlog_t* log = lcm_eventlog_create(out.c_str(), "w");
  if (!log) {
    std::fprintf(stderr, "exoid_logger: error: cannot write '%s'\n", out.c_str());
    return 1;
  }
  struct sigaction sa {};
  sa.sa_handler = onSignal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  if (!quiet) std::fprintf(stderr, "exoid_logger: recording %s -> %s\n", hostport.c_str(), out.c_str());

  std::map<std::string, long> per_channel;
  long events = 0;
  bool write_error = false;
  const exoid::lcmwire::UdpmReceiver::Handler record = [&](const std::string& channel, const uint8_t* data,
                                                           size_t size, int64_t t) {
    lcm_eventlog_event_t e{};
    e.timestamp = t;
    e.channellen = static_cast<int32_t>(channel.size());
    e.channel = const_cast<char*>(channel.data());
    e.datalen = static_cast<int32_t>(size);
    e.data = const_cast<uint8_t*>(data);
    if (lcm_eventlog_write_event(log, &e) != 0) write_error = true;
    ++per_channel[channel];
    ++events;
  };
  while (!g_stop && !write_error) receiver->poll(200, record);
  receiver->drain(record);  // what arrived before the stop request
  lcm_eventlog_destroy(log);
  std::fprintf(stderr, "exoid_logger: %ld events written to %s; malformed datagrams %ld, incomplete messages %ld\n",
               events, out.c_str(), receiver->malformed(), receiver->incomplete());
  for (const auto& [channel, count] : per_channel) std::fprintf(stderr, "  %-24s %ld\n", channel.c_str(), count);
  if (write_error) {
    std::fprintf(stderr, "exoid_logger: error: writing '%s' failed\n", out.c_str());
    return 1;
  }
  return 0;
}
