#pragma once
// The live view (`exo_sim --view`, `exoid experiment --view`): a window drawing the running robot the way
// `exoid render` draws a recorded one (scene.hpp), from the same channels (EXO_TRUTH, EXO_CONTROLLER_STATUS,
// EXO_ESTIMATE, EXO_PLATE_*), on its own thread and its own LCM subscription: the sim's loop never waits for it.
#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "exoid/sim/config.hpp"

namespace exoid::render {

struct LiveViewOptions {
  std::string mjcf_path;   ///< the scene (the sim's MJCF)
  std::string urdf_path;   ///< the model naming the joints and the estimate's parameters
  std::string lcm_url;     ///< the run's LCM URL (normalised, ttl=0)
  sim::Scenario scenario;  ///< its payloads are drawn
  std::string view = "iso";  ///< initial camera; keys 1-4: front, side, back, iso
  int width = 960, height = 720;
  double fps = 30.0;
};

/// "" when a window can open here, else why not (one line: no display).
std::string liveViewUnavailable();

/// The window's thread: started by start(), stopped (window closed, thread joined) by the destructor.
class LiveView {
 public:
  /// Starts the window, or returns nullptr with *why when no display exists or it cannot open.
  static std::unique_ptr<LiveView> start(const LiveViewOptions& options, std::string* why);
  ~LiveView();
  LiveView(const LiveView&) = delete;
  LiveView& operator=(const LiveView&) = delete;

 private:
  LiveView() = default;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace exoid::render
