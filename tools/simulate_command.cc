#include "tools/simulate_command.h"

#include <CLI/CLI.hpp>
#include <Eigen/Dense>
#include <cstdio>
#include <filesystem>
#include <utility>

#include "core/logging.h"
#include "storage/env.h"
#include "storage/features_csv_writer.h"
#include "storage/g2o_writer.h"
#include "storage/native_log_reader.h"
#include "storage/tum_writer.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"
#include "tools/streaming_campus_simulator.h"

namespace graphslam::tools {

// zstd level of `simulate --streaming --compress`: zstd's default, ~4x on the
// log's text at a few hundred MB/s on one worker thread.
constexpr int kLogZstdLevel = 3;
namespace {

// Writes the truth through the problem's own writers: the true values are
// swapped in for the writes and swapped back whatever happens.
Status WriteGroundTruth(SimulatedCampus* campus, const std::string& tum_path,
                        const std::string& features_path) {
  core::Problem2d& problem = campus->problem;
  std::swap(problem.poses, campus->true_poses);
  std::swap(problem.features, campus->true_features);
  Status status = storage::WriteTum(problem, tum_path);
  if (status.ok()) status = storage::WriteFeaturesCsv(problem, features_path);
  std::swap(problem.poses, campus->true_poses);
  std::swap(problem.features, campus->true_features);
  return status;
}

// g2o keeps a motion's information in the frame of its from-pose, which
// storage::WriteG2o takes from the written (dead-reckoned) pose values. R_t
// only rotates with theta (V(theta) = diag(R(theta), 1) V(0), and the floor is
// isotropic in x, y), so evaluating it at those values instead of the truth
// gives the g2o edge exactly the local information the truth implies.
void ExpressMotionInformationAtGuesses(const core::VelocityNoise& noise,
                                       core::Problem2d* problem) {
  for (core::VelocityMotionConstraint& motion : problem->motions) {
    const Eigen::Matrix3d covariance = core::VelocityMotionCovariance(
        problem->poses[static_cast<size_t>(motion.from)], motion.control, noise);
    const Eigen::Matrix3d information = covariance.inverse();
    motion.information = 0.5 * (information + information.transpose());
  }
}

}  // namespace

void AddSimulateCommand(CLI::App* app, SimulateCommandOptions* options, int* exit_code) {
  CLI::App* simulate = app->add_subcommand(
      "simulate", "Generate a synthetic campus data set (measurements + ground truth)");
  CampusSimulatorOptions& sim = options->simulator;
  simulate->add_option("-o,--output", options->output_dir, "output folder (created if missing)")
      ->required();
  simulate->add_option("--format", options->format, "measurement file format: native, g2o")
      ->capture_default_str();
  simulate->add_option("--poses", sim.poses, "poses in total (split over the runs)")
      ->check(Integer(2))
      ->capture_default_str();
  simulate->add_option("--features", sim.features, "landmarks (0: from the campus size)")
      ->check(Integer(0))
      ->capture_default_str();
  simulate->add_option("--runs", sim.runs, "independent drives through the same campus")
      ->check(Integer(1, std::numeric_limits<int>::max()))
      ->capture_default_str();
  simulate->add_option("--gps-every", sim.gps_every, "a GPS fix every K poses (0: none)")
      ->check(Integer(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  simulate->add_option("--seed", sim.seed, "random seed")->capture_default_str();
  simulate->add_option("--block-size", sim.block_size, "street pitch [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--street-width", sim.street_width, "street width [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--speed", sim.speed, "robot speed [m/s]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--dt", sim.dt, "time between poses [s]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--sensor-range", sim.sensor_range, "sensor range [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--range-sigma", sim.range_sigma, "range noise [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--bearing-sigma", sim.bearing_sigma, "bearing noise [rad]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--gps-sigma", sim.gps_sigma, "GPS noise [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  simulate->add_option("--landmark-spacing", options->landmark_spacing,
                       "MIN MAX: landmarks stand U(MIN, MAX) m apart along each side of a "
                       "street (default 6 10); a small spacing makes the dense landmark fields "
                       "of scaling runs (10^8 features over 10^6 poses)")
      ->check(PositiveReal())
      ->expected(2);
  simulate->add_option("--alpha", options->alpha,
                       "control noise a1..a6 (Probabilistic Robotics Table 5.3; default "
                       "0.01 0.001 0.00003 0.01 0.00003 0.01)")
      ->check(NonNegativeReal())
      ->expected(6);
  simulate->add_flag("--streaming", options->streaming,
                     "write as the robot drives, world generated per street segment: bounded "
                     "memory for 10^8 features (native format; a different file per seed)");
  simulate->add_flag("--compress", options->compress,
                     "with --streaming: write the log zstd-compressed, as log.graphslam.zst "
                     "(about 4x smaller; ingest and solve read it transparently)");
  simulate->add_flag("-q,--quiet", options->quiet, "no summary on the terminal");
  simulate->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  AddSimulate3dOptions(simulate, &options->sim3d);
  simulate->callback([options, exit_code]() { *exit_code = RunSimulateCommand(*options); });
}

namespace {

int Fail(const Status& status) {
  std::fprintf(stderr, "graphslam simulate: %s\n", status.ToString().c_str());
  return ExitCodeFor(status);
}

int Usage(const std::string& message) {
  std::fprintf(stderr, "graphslam simulate: %s\n", message.c_str());
  return kExitUsage;
}

// The simulator's options from the command's: --alpha, --landmark-spacing,
// the feature id base; an error is a usage error (its message).
StatusOr<CampusSimulatorOptions> SimulatorOptions(const SimulateCommandOptions& options) {
  CampusSimulatorOptions simulator = options.simulator;
  if (!options.alpha.empty()) {
    if (options.alpha.size() != 6) {
      return Status::InvalidArgument("--alpha takes 6 values a1..a6, got " +
                                     std::to_string(options.alpha.size()));
    }
    for (int i = 0; i < 6; ++i) simulator.noise.alpha[i] = options.alpha[static_cast<size_t>(i)];
  }
  if (!options.landmark_spacing.empty()) {
    if (options.landmark_spacing.size() != 2) {
      return Status::InvalidArgument("--landmark-spacing takes 2 values MIN MAX, got " +
                                     std::to_string(options.landmark_spacing.size()));
    }
    simulator.min_landmark_spacing = options.landmark_spacing[0];
    simulator.max_landmark_spacing = options.landmark_spacing[1];
  }
  // Pose and feature ids share one id space (g2o): feature ids start at 10^6,
  // or at the first power of ten not below the pose count for larger runs.
  while (simulator.feature_id_base < simulator.poses) simulator.feature_id_base *= 10;
  GS_RETURN_IF_ERROR(simulator.Validate());
  return simulator;
}

// --streaming: the world generated per street segment, the log written as
// the robot drives.
int RunStreaming(const SimulateCommandOptions& options, const CampusSimulatorOptions& simulator) {
  if (options.format != "native") return Usage("--streaming writes the native format only");
  StreamingCampusSummary summary;
  if (Status status = SimulateCampusStreaming(simulator, options.output_dir, &summary,
                                              options.compress ? kLogZstdLevel : 0);
      !status.ok())
    return Fail(status);
  if (!options.quiet) {
    std::printf(
        "Simulated (streaming) a campus of %d x %d intersections (seed %u) with %lld "
        "landmarks (%lld observed); %lld poses in %d run(s) over %.0f m, %lld motion controls, "
        "%lld range-bearing observations, %lld GPS fixes. Wrote %s.\n",
        summary.grid_columns, summary.grid_rows, simulator.seed,
        static_cast<long long>(summary.landmarks),
        static_cast<long long>(summary.observed_features), static_cast<long long>(summary.poses),
        simulator.runs, summary.distance_travelled, static_cast<long long>(summary.motions),
        static_cast<long long>(summary.observations), static_cast<long long>(summary.gps),
        options.output_dir.c_str());
  }
  return kExitOk;
}

void PrintCampusSummary(const CampusSimulatorOptions& sim, const SimulatedCampus& campus,
                        const std::string& measurements, const std::string& tum,
                        const std::string& features) {
  const core::Problem2d& problem = campus.problem;
  const double width = (campus.grid_columns - 1) * sim.block_size;
  const double height = (campus.grid_rows - 1) * sim.block_size;
  std::printf(
      "Simulated a campus of %d x %d intersections (%.0f m x %.0f m, %.0f m blocks, seed %u) "
      "with %d landmarks (%lld observed); %d poses in %d run(s) over %.0f m of driving, "
      "%zu motion controls, %zu range-bearing observations (%.1f per pose), %zu GPS fixes. "
      "Wrote %s, %s and %s.\n",
      campus.grid_columns, campus.grid_rows, width, height, sim.block_size, sim.seed,
      problem.num_features(), static_cast<long long>(campus.observed_features),
      problem.num_poses(), sim.runs, campus.distance_travelled, problem.motions.size(),
      problem.observations.size(),
      static_cast<double>(problem.observations.size()) / problem.num_poses(), problem.gps.size(),
      measurements.c_str(), tum.c_str(), features.c_str());
}

// The whole campus in memory, then the measurements (native log or g2o) and
// the ground truth (TUM trajectory, features CSV).
int RunInMemory(const SimulateCommandOptions& options, const CampusSimulatorOptions& simulator) {
  if (options.compress) return Usage("--compress needs --streaming");
  StatusOr<SimulatedCampus> simulated = SimulateCampus(simulator);
  if (!simulated.ok()) return Fail(simulated.status());
  SimulatedCampus campus = std::move(simulated).value();

  const std::filesystem::path folder(options.output_dir);
  const std::string measurements =
      (folder / (options.format == "g2o" ? "graph.g2o" : "log.graphslam")).string();
  const std::string tum = (folder / "ground_truth.tum").string();
  const std::string features = (folder / "ground_truth_features.csv").string();
  if (options.format == "g2o") ExpressMotionInformationAtGuesses(simulator.noise, &campus.problem);
  const Status written = options.format == "g2o"
                             ? storage::WriteG2o(campus.problem, measurements)
                             : storage::WriteNativeLog(campus.problem, measurements);
  if (!written.ok()) return Fail(written);
  if (Status status = WriteGroundTruth(&campus, tum, features); !status.ok()) return Fail(status);
  if (!options.quiet) PrintCampusSummary(simulator, campus, measurements, tum, features);
  return kExitOk;
}

}  // namespace

int RunSimulateCommand(const SimulateCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  if (options.output_dir.empty()) return Usage("no output folder given (-o DIR)");
  if (options.sim3d.enabled) {
    return RunSimulate3dCommand(options.output_dir, options.sim3d, options.simulator.seed,
                                options.quiet);
  }
  if (options.format != "native" && options.format != "g2o") {
    return Usage("--format must be 'native' or 'g2o', got '" + options.format + "'");
  }
  StatusOr<CampusSimulatorOptions> simulator = SimulatorOptions(options);
  if (!simulator.ok()) return Usage(simulator.status().message());
  if (Status status = storage::Env::Default()->CreateDir(options.output_dir); !status.ok())
    return Fail(status);
  if (storage::Env::Default()->KindOf(options.output_dir) != storage::FileKind::kDirectory) {
    return Fail(Status::IOError(options.output_dir + " is not a folder"));
  }
  return options.streaming ? RunStreaming(options, *simulator) : RunInMemory(options, *simulator);
}

}  // namespace graphslam::tools
