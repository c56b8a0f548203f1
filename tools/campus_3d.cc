#include "tools/campus_3d.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace graphslam::map {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTrunkRadius = 0.25, kTrunkHeight = 3.0, kCrownHeight = 4.5;

double Uniform(std::mt19937_64& rng) {  // [0, 1)
  return static_cast<double>(rng() >> 11) * (1.0 / 9007199254740992.0);
}
double Normal(std::mt19937_64& rng) {  // Box-Muller
  const double u1 = 1.0 - Uniform(rng), u2 = Uniform(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

double RayBox(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Box& b) {
  double t0 = 0.0, t1 = kInf;
  for (int a = 0; a < 3; ++a) {
    if (std::abs(d[a]) < 1e-15) {
      if (o[a] < b.lo[a] || o[a] > b.hi[a]) return kInf;
      continue;
    }
    double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return kInf;
  }
  return t0 > 0.0 ? t0 : kInf;
}

double RaySphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c,
                 double r) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(d), cc = oc.squaredNorm() - r * r;
  const double disc = b * b - cc;
  if (disc < 0) return kInf;
  const double t = -b - std::sqrt(disc);
  return t > 0 ? t : kInf;
}

double RayCylinder(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector2d& c,
                   double r, double z0, double z1) {
  const Eigen::Vector2d oc = o.head<2>() - c, dd = d.head<2>();
  const double a = dd.squaredNorm();
  if (a < 1e-15) return kInf;
  const double b = oc.dot(dd), cc = oc.squaredNorm() - r * r;
  const double disc = b * b - a * cc;
  if (disc < 0) return kInf;
  const double t = (-b - std::sqrt(disc)) / a;
  if (t <= 0) return kInf;
  const double z = o.z() + t * d.z();
  return (z >= z0 && z <= z1) ? t : kInf;
}

}  // namespace

Status Campus3dOptions::Validate() const {
  auto positive = [](const char* name, double v) {
    return v > 0 && std::isfinite(v) ? Status::Ok()
                                     : Status::InvalidArgument(std::string(name) + " must be > 0");
  };
  if (columns < 1 || rows < 1) return Status::InvalidArgument("columns and rows must be >= 1");
  GS_RETURN_IF_ERROR(positive("block_size", block_size));
  GS_RETURN_IF_ERROR(positive("street_width", street_width));
  if (street_width >= block_size) return Status::InvalidArgument("street_width must be < block_size");
  GS_RETURN_IF_ERROR(positive("min_height", min_height));
  if (max_height < min_height) return Status::InvalidArgument("max_height must be >= min_height");
  GS_RETURN_IF_ERROR(positive("tree_spacing", tree_spacing));
  GS_RETURN_IF_ERROR(positive("pose_spacing", pose_spacing));
  GS_RETURN_IF_ERROR(positive("sensor_height", sensor_height));
  GS_RETURN_IF_ERROR(positive("max_range", max_range));
  if (beams < 1) return Status::InvalidArgument("beams must be >= 1");
  if (!(range_sigma >= 0)) return Status::InvalidArgument("range_sigma must be >= 0");
  return Status::Ok();
}

Campus3d MakeCampus3d(const Campus3dOptions& options) {
  Campus3d campus;
  campus.options = options;
  std::mt19937_64 rng(options.seed);
  const double b = options.block_size, hw = 0.5 * options.street_width;
  for (int i = 0; i < options.columns; ++i) {
    for (int j = 0; j < options.rows; ++j) {
      const double x0 = i * b + hw, x1 = (i + 1) * b - hw, y0 = j * b + hw, y1 = (j + 1) * b - hw;
      const double ground = campus.GroundZ(0.5 * (x0 + x1), 0.5 * (y0 + y1));
      const double h = options.min_height + (options.max_height - options.min_height) * Uniform(rng);
      // The base reaches below the lowest ground corner.
      const double base = std::min({campus.GroundZ(x0, y0), campus.GroundZ(x1, y0),
                                    campus.GroundZ(x0, y1), campus.GroundZ(x1, y1)}) - 1.0;
      campus.buildings.push_back({Eigen::Vector3d(x0, y0, base), Eigen::Vector3d(x1, y1, ground + h)});
    }
  }
  // Trees on both sides of each street segment, clear of the intersections.
  const double offset = hw - options.tree_setback;
  const double clear = hw + 2.0;
  for (int along_x = 0; along_x < 2; ++along_x) {
    const int lines = along_x ? options.rows + 1 : options.columns + 1;
    const int segments = along_x ? options.columns : options.rows;
    for (int line = 0; line < lines; ++line) {
      for (int s = 0; s < segments; ++s) {
        for (double u = s * b + clear; u <= (s + 1) * b - clear; u += options.tree_spacing) {
          for (double side : {-offset, offset}) {
            const Eigen::Vector2d xy = along_x ? Eigen::Vector2d(u, line * b + side)
                                               : Eigen::Vector2d(line * b + side, u);
            campus.trees.push_back({xy});
          }
        }
      }
    }
  }
  return campus;
}

std::vector<int> Campus3d::NearbyTrees(const Eigen::Vector3d& o, double range) const {
  std::vector<int> out;
  const double reach = range + options.crown_radius + 1.0;
  for (size_t i = 0; i < trees.size(); ++i) {
    if ((trees[i].xy - o.head<2>()).squaredNorm() <= reach * reach) out.push_back(static_cast<int>(i));
  }
  return out;
}

double Campus3d::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range,
                      const std::vector<int>* nearby_trees) const {
  double best = kInf;
  // Ground plane z = a x + b y.
  const double a = options.slope_x, bb = options.slope_y;
  const double denom = d.z() - a * d.x() - bb * d.y();
  if (std::abs(denom) > 1e-12) {
    const double t = (a * o.x() + bb * o.y() - o.z()) / denom;
    if (t > 0) best = t;
  }
  // Only objects whose footprint can be reached.
  const double reach = std::min(best, max_range);
  const Eigen::Vector2d lo = o.head<2>() - Eigen::Vector2d::Constant(reach);
  const Eigen::Vector2d hi = o.head<2>() + Eigen::Vector2d::Constant(reach);
  const double bsz = options.block_size;
  const int i0 = std::max(0, static_cast<int>(std::floor(lo.x() / bsz)));
  const int i1 = std::min(options.columns - 1, static_cast<int>(std::floor(hi.x() / bsz)));
  const int j0 = std::max(0, static_cast<int>(std::floor(lo.y() / bsz)));
  const int j1 = std::min(options.rows - 1, static_cast<int>(std::floor(hi.y() / bsz)));
  for (int i = i0; i <= i1; ++i) {
    for (int j = j0; j <= j1; ++j) {
      best = std::min(best, RayBox(o, d, buildings[static_cast<size_t>(i * options.rows + j)]));
    }
  }
  auto test_tree = [&](const Tree& tree) {
    if (tree.xy.x() < lo.x() - 3 || tree.xy.x() > hi.x() + 3 || tree.xy.y() < lo.y() - 3 ||
        tree.xy.y() > hi.y() + 3) {
      return;
    }
    const double g = GroundZ(tree.xy.x(), tree.xy.y());
    best = std::min(best, RayCylinder(o, d, tree.xy, kTrunkRadius, g - 1.0, g + kTrunkHeight));
    best = std::min(best, RaySphere(o, d, Eigen::Vector3d(tree.xy.x(), tree.xy.y(), g + kCrownHeight),
                                    options.crown_radius));
  };
  if (nearby_trees != nullptr) {
    for (int i : *nearby_trees) test_tree(trees[static_cast<size_t>(i)]);
  } else {
    for (const Tree& tree : trees) test_tree(tree);
  }
  return best <= max_range ? best : kInf;
}

void Campus3dTrajectory(const Campus3d& campus, std::vector<core::Pose3>* poses,
                        std::vector<int32_t>* runs) {
  const Campus3dOptions& o = campus.options;
  const double b = o.block_size;
  poses->clear();
  runs->clear();
  auto drive = [&](Eigen::Vector2d from, Eigen::Vector2d to, int32_t run) {
    const double length = (to - from).norm();
    const Eigen::Vector2d h = (to - from) / length;
    const Eigen::Vector3d n = Eigen::Vector3d(-o.slope_x, -o.slope_y, 1.0).normalized();
    Eigen::Vector3d x(h.x(), h.y(), o.slope_x * h.x() + o.slope_y * h.y());
    x.normalize();
    const Eigen::Vector3d y = n.cross(x).normalized();
    x = y.cross(n);
    Eigen::Matrix3d r;
    r << x, y, n;
    const int steps = static_cast<int>(std::floor(length / o.pose_spacing));
    for (int k = 0; k < steps; ++k) {
      const Eigen::Vector2d p = from + (k * o.pose_spacing) * h;
      core::Pose3 pose;
      pose.q = Eigen::Quaterniond(r).normalized();
      pose.t = Eigen::Vector3d(p.x(), p.y(), campus.GroundZ(p.x(), p.y())) + o.sensor_height * n;
      poses->push_back(pose);
      runs->push_back(run);
    }
  };
  const double width = o.columns * b, height = o.rows * b;
  for (int j = 0; j <= o.rows; ++j) {  // run 0: the row streets, boustrophedon
    const double y = j * b;
    if (j % 2 == 0) {
      drive({0, y}, {width, y}, 0);
      if (j < o.rows) drive({width, y}, {width, y + b}, 0);
    } else {
      drive({width, y}, {0, y}, 0);
      if (j < o.rows) drive({0, y}, {0, y + b}, 0);
    }
  }
  for (int i = 0; i <= o.columns; ++i) {  // run 1: the column streets
    const double x = i * b;
    if (i % 2 == 0) {
      drive({x, 0}, {x, height}, 1);
    } else {
      drive({x, height}, {x, 0}, 1);
    }
  }
}

Status SimulateCampus3dScans(const Campus3d& campus, const std::function<Status(Scan&&)>& sink) {
  GS_RETURN_IF_ERROR(campus.options.Validate());
  std::vector<core::Pose3> poses;
  std::vector<int32_t> runs;
  Campus3dTrajectory(campus, &poses, &runs);
  std::mt19937_64 rng(campus.options.seed ^ 0x5ca115ULL);
  const int beams = campus.options.beams;
  for (size_t k = 0; k < poses.size(); ++k) {
    Scan scan;
    scan.pose = static_cast<int64_t>(k);
    scan.run = runs[k];
    scan.sensor_pose = poses[k];
    const Eigen::Matrix3d r = poses[k].rotation();
    const std::vector<int> nearby = campus.NearbyTrees(poses[k].t, campus.options.max_range);
    for (int beam = 0; beam < beams; ++beam) {
      const double angle = 2.0 * kPi * (beam + 0.5) / beams;
      const Eigen::Vector3d local(0.0, std::cos(angle), std::sin(angle));
      const double t = campus.Cast(poses[k].t, r * local, campus.options.max_range, &nearby);
      if (!std::isfinite(t)) continue;
      const double noisy = t + campus.options.range_sigma * Normal(rng);
      scan.points.push_back((noisy * local).cast<float>());
    }
    GS_RETURN_IF_ERROR(sink(std::move(scan)));
  }
  return Status::Ok();
}

}  // namespace graphslam::map
