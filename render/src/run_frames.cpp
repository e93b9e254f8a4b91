#include "exoid/render/run_frames.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "exoid/estimator/dataset.hpp"
#include "exoid/model/dynamics.hpp"
#include "exoid/model/kinematics.hpp"
#include "exoid/model/regressor.hpp"

namespace exoid::render {

namespace {
// Index of the last element of `v` (sorted by tick) with tick <= `tick`, or -1; `hint` only moves forward.
template <class T>
long lastAtOrBefore(const std::vector<T>& v, int64_t tick, long hint) {
  long i = std::max(hint, -1L);
  while (i + 1 < static_cast<long>(v.size()) && v[static_cast<size_t>(i + 1)].tick <= tick) ++i;
  return i;
}

template <class T>
std::vector<T> sortedByTick(const std::vector<T>& v) {
  std::vector<T> s = v;
  std::stable_sort(s.begin(), s.end(), [](const T& a, const T& b) { return a.tick < b.tick; });
  return s;
}

// The plate's reading as a ground reaction at its centre of pressure (world).
void plateArrow(const ForcePlateSample& p, FrameState& f) {
  Eigen::Vector3d force, moment;
  estimator::footWrenchFromPlate(p, force, moment);
  f.force[p.plate] = force;
  f.loaded[p.plate] = force.z() > kLoadedForce;
  f.cop[p.plate] = p.plate_position + p.plate_orientation * p.cop;
}

// CoM of the estimate's parameters at the truth pose: the base frame's centroidal CoM moved to the world.
bool estimateCom(const Model& model, const EstimatorOutputSample& e, const State& s, DynamicsData& dyn,
                 Eigen::Vector3d& com) {
  if (!e.valid || e.params.size() != model.nparams()) return false;
  forwardKinematics(model, dyn.kin, s);
  centroidal(model, e.params, dyn);
  if (!dyn.com.allFinite()) return false;
  com = s.base_position + s.base_orientation * dyn.com;
  return true;
}
}  // namespace

bool sampleRunFrames(const Model& model, const intake::RunLog& log, const FrameTimes& times,
                     std::vector<FrameState>& frames, std::string* err) {
  frames.clear();
  if (log.truth.empty()) {
    if (err) *err = "no ground-truth message (EXO_TRUTH) in the log: nothing to render";
    return false;
  }
  const auto truth = sortedByTick(log.truth);
  const auto status = sortedByTick(log.status);
  const auto estimates = sortedByTick(log.estimates);
  const std::vector<ForcePlateSample> plates[2] = {sortedByTick(log.plates[0]), sortedByTick(log.plates[1])};
  const double first = 1e-3 * static_cast<double>(truth.front().tick);
  const double last = 1e-3 * static_cast<double>(truth.back().tick);
  const double from = std::max(times.from_s, first), to = times.to_s < 0 ? last : std::min(times.to_s, last);
  if (!(from <= to) || !(times.fps > 0)) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "the window --from/--to holds no frame of the run (its truth covers %.3f to %.3f s)",
                  first, last);
    if (err) *err = buf;
    return false;
  }
  DynamicsData dyn(model);
  long it = -1, is = -1, ie = -1, ip[2] = {-1, -1};
  const long n = static_cast<long>(std::floor((to - from) * times.fps + 1e-9)) + 1;
  frames.resize(static_cast<size_t>(n));
  for (long k = 0; k < n; ++k) {
    FrameState& f = frames[static_cast<size_t>(k)];
    const int64_t tick = std::llround((from + static_cast<double>(k) / times.fps) * 1e3);
    it = std::max(lastAtOrBefore(truth, tick, it), 0L);
    const GroundTruthSample& g = truth[static_cast<size_t>(it)];
    f.tick = g.tick, f.t = 1e-3 * static_cast<double>(g.tick);
    f.base_position = g.base_position, f.base_orientation = g.base_orientation, f.q = g.q, f.com_true = g.com;
    if ((is = lastAtOrBefore(status, tick, is)) >= 0) {
      f.has_status = true, f.com_ref = status[static_cast<size_t>(is)].com_ref, f.com_model = status[static_cast<size_t>(is)].com;
    }
    if ((ie = lastAtOrBefore(estimates, tick, ie)) >= 0)
      f.has_estimate = estimateCom(model, estimates[static_cast<size_t>(ie)], estimator::stateFromTruth(model, g), dyn,
                                   f.com_estimate);
    for (int side = 0; side < 2; ++side)
      if ((ip[side] = lastAtOrBefore(plates[side], tick, ip[side])) >= 0) plateArrow(plates[side][static_cast<size_t>(ip[side])], f);
  }
  return true;
}

size_t largestComExcursion(const std::vector<FrameState>& frames) {
  size_t best = 0;
  double dmax = -1.0;
  for (size_t i = 0; i < frames.size(); ++i) {
    const double d = (frames[i].com_true - frames.front().com_true).head<2>().norm();
    if (d > dmax) dmax = d, best = i;
  }
  return best;
}

}  // namespace exoid::render
