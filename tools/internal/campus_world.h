// The campus world shared by the in-memory simulator (campus_simulator.h) and
// the streaming one (streaming_campus_simulator.h): the random source, the
// street grid, and the planned street path with its pure-pursuit geometry.
// Moved verbatim from campus_simulator.cc, so outputs of existing seeds are
// unchanged. See campus_simulator.h for the model.
//
// THREAD SAFETY: plain values; a Random or StreetPath per thread.
// ALLOCATION: StreetPath keeps its planned segments (O(distance / block)).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

#include "core/angle.h"
#include "core/check.h"
#include "core/se2.h"
#include "tools/campus_simulator.h"

namespace graphslam::tools::internal {

// Uniform and normal draws from one std::mt19937_64 (whose sequence the
// standard fixes), with our own transforms so the draws do not depend on the
// standard library's distributions.
class Random {
 public:
  explicit Random(uint64_t seed) : engine_(seed) {}

  // [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double low, double high) { return low + (high - low) * Uniform(); }
  // 0..n-1, n > 0.
  int64_t UniformInt(int64_t n) {
    GS_DCHECK(n > 0);
    return std::min<int64_t>(static_cast<int64_t>(Uniform() * static_cast<double>(n)), n - 1);
  }
  // N(0, 1) by Box-Muller; the second value of each pair is kept for the next call.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double u1 = 1.0 - Uniform();  // (0, 1]: log is finite
    const double u2 = Uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    const double angle = 2.0 * std::numbers::pi * u2;
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }
  double Normal(double sigma) { return sigma * Normal(); }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

// Directions 0: +x, 1: +y, 2: -x, 3: -y; left of d is d + 1.
inline constexpr int kStepX[4] = {1, 0, -1, 0};
inline constexpr int kStepY[4] = {0, 1, 0, -1};

inline core::Point2 DirectionVector(int direction) {
  return core::Point2(kStepX[direction], kStepY[direction]);
}
inline double DirectionAngle(int direction) { return 0.5 * std::numbers::pi * direction; }

struct Grid {
  int columns = 0;
  int rows = 0;
  double block_size = 0;
  bool Contains(int x, int y) const { return x >= 0 && x < columns && y >= 0 && y < rows; }
  core::Point2 Node(int x, int y) const { return core::Point2(x * block_size, y * block_size); }
  int64_t Segments() const {
    return static_cast<int64_t>(columns) * (rows - 1) + static_cast<int64_t>(rows) * (columns - 1);
  }
};

// Where a run starts: a random intersection and a street leaving it, and the
// true pose there (heading along the street).
struct RunStart {
  int x = 0;
  int y = 0;
  int direction = 0;
  core::Pose2 truth;
};
inline RunStart DrawRunStart(const Grid& grid, Random* random) {
  RunStart start;
  start.x = static_cast<int>(random->UniformInt(grid.columns));
  start.y = static_cast<int>(random->UniformInt(grid.rows));
  int directions[4];
  int count = 0;
  for (int d = 0; d < 4; ++d)
    if (grid.Contains(start.x + kStepX[d], start.y + kStepY[d])) directions[count++] = d;
  start.direction = directions[random->UniformInt(count)];
  start.truth = core::Pose2(start.x * grid.block_size, start.y * grid.block_size,
                            core::WrapAngle(DirectionAngle(start.direction)));
  return start;
}

// The guess of a run's first pose: the truth for the first run (it fixes the
// frame), off by the initial sigmas for later runs (they start unaligned).
inline core::Pose2 RunStartGuess(const CampusSimulatorOptions& options, int run,
                                 const core::Pose2& truth, Random* random) {
  core::Pose2 guess = truth;
  if (run > 0) {
    guess.x() += random->Normal(options.initial_position_sigma);
    guess.y() += random->Normal(options.initial_position_sigma);
    guess.z() = core::WrapAngle(guess.z() + random->Normal(options.initial_heading_sigma));
  }
  return guess;
}

inline double ExpectedLandmarksPerSegment(const CampusSimulatorOptions& options) {
  const double usable = options.block_size - options.street_width;
  const double mean_spacing = 0.5 * (options.min_landmark_spacing + options.max_landmark_spacing);
  return 2.0 * (usable / mean_spacing + 0.5);
}

// Grows the grid by one column or row, keeping it near-square.
inline void Grow(Grid* grid) {
  if (grid->columns <= grid->rows) {
    ++grid->columns;
  } else {
    ++grid->rows;
  }
}

// A piece of the planned path: a line (curvature 0) or a circular arc.
struct PathSegment {
  core::Point2 start = core::Point2::Zero();
  double heading = 0;    // at start
  double curvature = 0;  // 1/m, positive = left
  double length = 0;     // m
  double start_s = 0;    // arc length of the path at start
};

inline core::Point2 SegmentPosition(const PathSegment& segment, double local) {
  const double k = segment.curvature;
  const double h = segment.heading;
  if (k == 0.0) return segment.start + local * core::Point2(std::cos(h), std::sin(h));
  return segment.start + core::Point2((std::sin(h + k * local) - std::sin(h)) / k,
                                      (std::cos(h) - std::cos(h + k * local)) / k);
}

// The planned route along the street centerlines, generated one leg at a time
// as the robot needs it. Arc length s = 0 is the start intersection.
class StreetPath {
 public:
  StreetPath(const Grid& grid, const CampusSimulatorOptions& options, int x, int y, int direction,
             Random* random)
      : grid_(grid),
        turn_radius_(options.turn_radius > 0 ? options.turn_radius : 0.5 * options.street_width),
        straight_probability_(options.straight_probability),
        random_(random),
        end_(grid.Node(x, y)),
        node_x_(x + kStepX[direction]),
        node_y_(y + kStepY[direction]),
        direction_(direction) {}

  // Plans legs until the path reaches arc length s.
  void ExtendTo(double s) {
    while (end_s_ < s) AddLeg();
  }

  core::Point2 Position(double s) const {
    const PathSegment& segment = SegmentAt(s);
    return SegmentPosition(segment, std::clamp(s - segment.start_s, 0.0, segment.length));
  }
  core::Point2 Tangent(double s) const {
    const PathSegment& segment = SegmentAt(s);
    const double h =
        segment.heading +
        segment.curvature * std::clamp(s - segment.start_s, 0.0, segment.length);
    return core::Point2(std::cos(h), std::sin(h));
  }

 private:
  const PathSegment& SegmentAt(double s) const {
    GS_CHECK(!segments_.empty());
    auto it = std::upper_bound(segments_.begin(), segments_.end(), s,
                               [](double value, const PathSegment& segment) {
                                 return value < segment.start_s;
                               });
    if (it != segments_.begin()) --it;
    return *it;
  }

  void Append(const core::Point2& start, double heading, double curvature, double length) {
    if (length <= 0.0) return;
    PathSegment segment;
    segment.start = start;
    segment.heading = heading;
    segment.curvature = curvature;
    segment.length = length;
    segment.start_s = end_s_;
    segments_.push_back(segment);
    end_s_ += length;
  }

  // Chooses the way on at the next intersection and plans the path up to the
  // end of the turn there.
  void AddLeg() {
    int candidates[3];
    double weights[3];
    int count = 0;
    const int options[3] = {direction_, (direction_ + 1) % 4, (direction_ + 3) % 4};
    const double option_weights[3] = {straight_probability_, 0.5 * (1.0 - straight_probability_),
                                      0.5 * (1.0 - straight_probability_)};
    for (int i = 0; i < 3; ++i) {
      if (grid_.Contains(node_x_ + kStepX[options[i]], node_y_ + kStepY[options[i]])) {
        candidates[count] = options[i];
        weights[count] = option_weights[i];
        ++count;
      }
    }
    // A grid of at least 2 x 2 always offers a left or a right turn.
    GS_CHECK(count > 0);
    double total = 0.0;
    for (int i = 0; i < count; ++i) total += weights[i];
    int next = candidates[count - 1];
    if (total > 0.0) {
      double draw = random_->Uniform() * total;
      for (int i = 0; i < count; ++i) {
        if (draw < weights[i]) {
          next = candidates[i];
          break;
        }
        draw -= weights[i];
      }
    } else {
      next = candidates[random_->UniformInt(count)];
    }

    const core::Point2 node = grid_.Node(node_x_, node_y_);
    const core::Point2 in = DirectionVector(direction_);
    const double heading = DirectionAngle(direction_);
    if (next == direction_) {
      Append(end_, heading, 0.0, (node - end_).dot(in));
      end_ = node;
    } else {
      const core::Point2 turn_start = node - turn_radius_ * in;
      Append(end_, heading, 0.0, (turn_start - end_).dot(in));
      const double curvature = (next == (direction_ + 1) % 4 ? 1.0 : -1.0) / turn_radius_;
      Append(turn_start, heading, curvature, 0.5 * std::numbers::pi * turn_radius_);
      end_ = node + turn_radius_ * DirectionVector(next);
    }
    node_x_ += kStepX[next];
    node_y_ += kStepY[next];
    direction_ = next;
  }

  const Grid& grid_;
  const double turn_radius_;
  const double straight_probability_;
  Random* random_;  // must outlive the path
  std::vector<PathSegment> segments_;
  double end_s_ = 0.0;
  core::Point2 end_;  // where the planned path ends
  int node_x_, node_y_;  // the next intersection
  int direction_;       // heading on the way to it
};

// Pure pursuit on the true pose: project it onto `path` (Newton steps along
// the tangent, never backwards; *s is the arc length reached so far) and steer
// at constant speed towards the point `lookahead` further on, with the
// curvature 2 y / |local|^2 of the arc through that point, clamped to
// max_omega.
inline core::VelocityControl PursuitControl(const CampusSimulatorOptions& options,
                                            const core::Pose2& truth, StreetPath* path,
                                            double* s) {
  path->ExtendTo(*s + options.lookahead + 2.0 * options.block_size);
  for (int iteration = 0; iteration < 3; ++iteration) {
    const double step = (truth.head<2>() - path->Position(*s)).dot(path->Tangent(*s));
    *s = std::max(*s, *s + std::clamp(step, -options.block_size, options.block_size));
  }
  const core::Point2 target = path->Position(*s + options.lookahead);
  const core::Point2 local = core::Rotation2(truth.z()).transpose() * (target - truth.head<2>());
  const double curvature = 2.0 * local.y() / std::max(local.squaredNorm(), 1e-12);
  core::VelocityControl control;
  control.v = options.speed;
  control.omega = std::clamp(options.speed * curvature, -options.max_omega, options.max_omega);
  control.dt = options.dt;
  return control;
}

// The next true pose: `control` executed with noise (Probabilistic Robotics
// Table 5.3: noisy v and omega, a final rotation gamma) plus the small
// isotropic floor min_sigma_xy / min_sigma_theta. The draws are made in a
// fixed order, so a seed gives the same trajectory in both simulators.
inline core::Pose2 ExecuteWithNoise(const CampusSimulatorOptions& options,
                                    const core::Pose2& truth,
                                    const core::VelocityControl& control, Random* random) {
  const double v2 = control.v * control.v;
  const double w2 = control.omega * control.omega;
  const double* a = options.noise.alpha;
  core::VelocityControl executed = control;
  executed.v += random->Normal(std::sqrt(a[0] * v2 + a[1] * w2));
  executed.omega += random->Normal(std::sqrt(a[2] * v2 + a[3] * w2));
  const double gamma = random->Normal(std::sqrt(a[4] * v2 + a[5] * w2));
  core::Pose2 next = core::PredictVelocityMotion(truth, executed);
  next.x() += random->Normal(options.noise.min_sigma_xy);
  next.y() += random->Normal(options.noise.min_sigma_xy);
  next.z() = core::WrapAngle(next.z() + gamma * options.dt +
                             random->Normal(options.noise.min_sigma_theta));
  return next;
}

}  // namespace graphslam::tools::internal
