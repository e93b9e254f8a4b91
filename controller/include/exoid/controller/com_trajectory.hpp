#pragma once
// CoM reference of the seed thesis's experiment protocol (section IV-A): a sequence of straight-line CoM
// moves inside the support polygon while standing on both feet, each with a cubic time law
//   p(t) = p_a + (p_b - p_a) s(tau),  s = 3 tau^2 - 2 tau^3,  tau = (t - t_i) / T   (zero velocity at both ends)
// followed by a hold. Targets are drawn deterministically from a seed (training and validation runs use
// different seeds), inside the support polygon shrunk by a safety margin.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "exoid/controller/config.hpp"
#include "exoid/controller/move_reach.hpp"

namespace exoid::controller {

/// Convex polygon in the world x-y plane (counter-clockwise vertices), fixed capacity: no allocation.
struct SupportPolygon {
  static constexpr int kMaxVertices = 16;
  std::array<Eigen::Vector2d, kMaxVertices> vertices{};
  int count = 0;

  /// Convex hull of `n` points (n <= kMaxVertices; extra points are ignored). Collinear points dropped.
  static SupportPolygon convexHull(const Eigen::Vector2d* points, int n);
  /// Hull of the rectangles of two soles: centre c_i, yaw (rotation about world z) psi_i, half sizes.
  static SupportPolygon fromSoles(const Eigen::Vector2d& c_right, double yaw_right, const Eigen::Vector2d& c_left,
                                  double yaw_left, double half_length, double half_width);
  /// Smallest distance from p to an edge line, positive inside, negative outside.
  double insideDistance(const Eigen::Vector2d& p) const;
  bool contains(const Eigen::Vector2d& p, double margin = 0.0) const { return count >= 3 && insideDistance(p) >= margin; }
  Eigen::Vector2d lower() const;  ///< bounding box corners
  Eigen::Vector2d upper() const;
};

/// Reference at one instant.
struct CoMReference {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();      ///< world, m
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();      ///< world, m/s
  Eigen::Vector3d acceleration = Eigen::Vector3d::Zero();  ///< world, m/s^2
  int move_index = -1;  ///< move in progress or holding its target (0-based); -1 before the first; moves() when done
  int moves_done = 0;   ///< moves whose motion phase has ended
  bool done = false;    ///< every move and its hold are over
};

/// Deterministic 64-bit generator (SplitMix64): identical sequences on every platform and standard library.
class SplitMix64 {
 public:
  explicit SplitMix64(uint64_t seed) : state_(seed) {}
  uint64_t next();
  /// Uniform in [0, 1) with 53 random bits.
  double uniform();
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }

 private:
  uint64_t state_;
};

class CoMTrajectory {
 public:
  enum class Status { Ok, EmptyPolygon, StartOutside, NoTarget };

  /// Reserves room for `max_moves` targets (setup; the only allocation).
  explicit CoMTrajectory(int max_moves = 0);

  /// Draws cfg.moves targets (needs cfg.moves <= the reserved count to stay allocation-free) from `seed`,
  /// starting at `start` (the current CoM, world), inside `polygon` shrunk by cfg.polygon_margin, each
  /// between cfg.min_move_distance and cfg.max_move_distance (horizontally) from the previous one, with a
  /// height offset from start.z() in [cfg.vertical_min, cfg.vertical_max], and admitted by `reach`
  /// (staticMomentReach). Deterministic in `seed`; a target the reach refuses costs one draw, like any other
  /// refused one (a reach beyond the polygon changes nothing).
  Status generate(const TrajectoryConfig& cfg, uint64_t seed, const Eigen::Vector3d& start,
                  const SupportPolygon& polygon, const MoveReach& reach = MoveReach{});

  /// Reference at time t (s) since the trajectory start (t < 0 reads as 0). Allocation-free.
  void sample(double t, CoMReference& out) const;

  bool ready() const { return ready_; }
  int moves() const { return static_cast<int>(targets_.size()); }
  const Eigen::Vector3d& start() const { return start_; }
  const Eigen::Vector3d& target(int i) const { return targets_[static_cast<size_t>(i)]; }
  /// Time at which move i begins (s since the trajectory start).
  double moveStartTime(int i) const { return initial_hold_ + i * (move_duration_ + hold_duration_); }
  double moveDuration() const { return move_duration_; }
  double holdDuration() const { return hold_duration_; }
  /// Total duration, known upfront: initial hold + moves * (move + hold).
  double duration() const { return moveStartTime(moves()); }
  uint64_t seed() const { return seed_; }

 private:
  bool ready_ = false;
  uint64_t seed_ = 0;
  double initial_hold_ = 0.0, move_duration_ = 0.0, hold_duration_ = 0.0;
  Eigen::Vector3d start_ = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> targets_;  // Vector3d has no alignment requirement
};

}  // namespace exoid::controller
