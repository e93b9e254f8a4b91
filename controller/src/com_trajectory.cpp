#include "exoid/controller/com_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace exoid::controller {

namespace {
double cross2(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}
}  // namespace

SupportPolygon SupportPolygon::convexHull(const Eigen::Vector2d* points, int n) {
  // Andrew's monotone chain on a fixed-size copy.
  std::array<Eigen::Vector2d, kMaxVertices> p{};
  n = std::min(n, kMaxVertices);
  for (int i = 0; i < n; ++i) p[static_cast<size_t>(i)] = points[i];
  std::sort(p.begin(), p.begin() + n, [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  std::array<Eigen::Vector2d, 2 * kMaxVertices> h{};
  int k = 0;
  for (int i = 0; i < n; ++i) {  // lower hull
    while (k >= 2 && cross2(h[static_cast<size_t>(k - 2)], h[static_cast<size_t>(k - 1)], p[static_cast<size_t>(i)]) <= 0.0) --k;
    h[static_cast<size_t>(k++)] = p[static_cast<size_t>(i)];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i) {  // upper hull
    while (k >= t && cross2(h[static_cast<size_t>(k - 2)], h[static_cast<size_t>(k - 1)], p[static_cast<size_t>(i)]) <= 0.0) --k;
    h[static_cast<size_t>(k++)] = p[static_cast<size_t>(i)];
  }
  SupportPolygon poly;
  poly.count = std::max(0, std::min(k - 1, kMaxVertices));
  for (int i = 0; i < poly.count; ++i) poly.vertices[static_cast<size_t>(i)] = h[static_cast<size_t>(i)];
  return poly;
}

SupportPolygon SupportPolygon::fromSoles(const Eigen::Vector2d& c_right, double yaw_right, const Eigen::Vector2d& c_left,
                                         double yaw_left, double half_length, double half_width) {
  std::array<Eigen::Vector2d, 8> corners{};
  const double sx[4] = {1.0, -1.0, -1.0, 1.0};
  const double sy[4] = {1.0, 1.0, -1.0, -1.0};
  for (int foot = 0; foot < 2; ++foot) {
    const double yaw = foot == 0 ? yaw_right : yaw_left;
    const Eigen::Vector2d& c = foot == 0 ? c_right : c_left;
    const Eigen::Rotation2Dd R(yaw);
    for (int i = 0; i < 4; ++i)
      corners[static_cast<size_t>(4 * foot + i)] = c + R * Eigen::Vector2d(sx[i] * half_length, sy[i] * half_width);
  }
  return convexHull(corners.data(), 8);
}

double SupportPolygon::insideDistance(const Eigen::Vector2d& p) const {
  double d = std::numeric_limits<double>::infinity();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector2d& a = vertices[static_cast<size_t>(i)];
    const Eigen::Vector2d& b = vertices[static_cast<size_t>((i + 1) % count)];
    const Eigen::Vector2d e = b - a;
    const double len = e.norm();
    if (len <= 0.0) continue;
    d = std::min(d, (e.x() * (p.y() - a.y()) - e.y() * (p.x() - a.x())) / len);  // left of a CCW edge = inside
  }
  return d;
}

Eigen::Vector2d SupportPolygon::lower() const {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  for (int i = 0; i < count; ++i) lo = lo.cwiseMin(vertices[static_cast<size_t>(i)]);
  return lo;
}

Eigen::Vector2d SupportPolygon::upper() const {
  Eigen::Vector2d hi = Eigen::Vector2d::Constant(-std::numeric_limits<double>::infinity());
  for (int i = 0; i < count; ++i) hi = hi.cwiseMax(vertices[static_cast<size_t>(i)]);
  return hi;
}

uint64_t SplitMix64::next() {
  uint64_t z = (state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  return z ^ (z >> 31);
}

double SplitMix64::uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }

CoMTrajectory::CoMTrajectory(int max_moves) { targets_.reserve(static_cast<size_t>(std::max(0, max_moves))); }

CoMTrajectory::Status CoMTrajectory::generate(const TrajectoryConfig& cfg, uint64_t seed,
                                              const Eigen::Vector3d& start, const SupportPolygon& polygon,
                                              const MoveReach& reach) {
  ready_ = false;
  targets_.clear();
  seed_ = seed;
  start_ = start;
  initial_hold_ = cfg.initial_hold;
  move_duration_ = cfg.move_duration;
  hold_duration_ = cfg.hold_duration;
  if (polygon.count < 3) return Status::EmptyPolygon;
  if (!polygon.contains(start.head<2>())) return Status::StartOutside;
  // Mix the seed once so that neighbouring seeds give unrelated sequences.
  SplitMix64 rng(seed ^ 0x5DEECE66DULL);
  const Eigen::Vector2d lo = polygon.lower(), hi = polygon.upper();
  Eigen::Vector2d previous = start.head<2>();
  for (int i = 0; i < cfg.moves; ++i) {
    bool found = false;
    for (int attempt = 0; attempt < cfg.max_sampling_attempts && !found; ++attempt) {
      const Eigen::Vector2d p(rng.uniform(lo.x(), hi.x()), rng.uniform(lo.y(), hi.y()));
      const double dist = (p - previous).norm();
      if (!polygon.contains(p, cfg.polygon_margin) || dist < cfg.min_move_distance || dist > cfg.max_move_distance ||
          !reach.admits(p))
        continue;
      const double dz = rng.uniform(cfg.vertical_min, cfg.vertical_max);
      targets_.emplace_back(p.x(), p.y(), start.z() + dz);
      previous = p;
      found = true;
    }
    if (!found) {
      targets_.clear();
      return Status::NoTarget;
    }
  }
  ready_ = true;
  return Status::Ok;
}

void CoMTrajectory::sample(double t, CoMReference& out) const {
  out.velocity.setZero();
  out.acceleration.setZero();
  const int n = moves();
  if (!ready_ || n == 0) {
    out.position = start_;
    out.move_index = -1;
    out.moves_done = 0;
    out.done = false;
    return;
  }
  t = std::max(t, 0.0);
  if (t < initial_hold_) {
    out.position = start_;
    out.move_index = -1;
    out.moves_done = 0;
    out.done = false;
    return;
  }
  const double slot = move_duration_ + hold_duration_;
  const int i = static_cast<int>(std::floor((t - initial_hold_) / slot));
  if (i >= n) {
    out.position = targets_.back();
    out.move_index = n;
    out.moves_done = n;
    out.done = true;
    return;
  }
  const Eigen::Vector3d& a = i == 0 ? start_ : targets_[static_cast<size_t>(i - 1)];
  const Eigen::Vector3d& b = targets_[static_cast<size_t>(i)];
  const double local = t - moveStartTime(i);
  out.move_index = i;
  out.done = false;
  if (local >= move_duration_) {  // holding target i
    out.position = b;
    out.moves_done = i + 1;
    return;
  }
  const double T = move_duration_;
  const double tau = local / T;
  const double s = tau * tau * (3.0 - 2.0 * tau);
  const double ds = 6.0 * tau * (1.0 - tau) / T;
  const double dds = (6.0 - 12.0 * tau) / (T * T);
  const Eigen::Vector3d d = b - a;
  out.position = a + s * d;
  out.velocity = ds * d;
  out.acceleration = dds * d;
  out.moves_done = i;
}

}  // namespace exoid::controller
