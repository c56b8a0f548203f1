#include "tools/job/job_runner.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "core/logging.h"
#include "core/robust_kernel.h"
#include "partition/association/association_driver.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/incremental_initialization.h"
#include "partition/initialization/progressive_initialization.h"
#include "storage/atomic_file.h"
#include "storage/directory_lock.h"
#include "storage/store_directory.h"
#include "storage/features_csv_writer.h"
#include "storage/g2o_writer.h"
#include "storage/native_log_reader.h"
#include "storage/solver_checkpoint.h"
#include "storage/stop_point.h"
#include "storage/tum_writer.h"
#include "tools/job/job_data.h"
#include "tools/job/job_export.h"
#include "tools/job/job_map.h"
#include "tools/job/job_memory_budget.h"
#include "tools/job/job_spec.h"
#include "tools/job/job_state.h"
#include "tools/job/report_html.h"
#include "tools/job/report_inputs.h"
#include "tools/memory_budget.h"
#include "tools/pipeline/solve_request.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

struct Context {
  JobSpec spec;
  std::string fingerprint;
  std::string work;  // OUTPUT/.job
  bool quiet = false;
  JobLog log;
  std::unique_ptr<ProgressDisplay> display;
  JobState state;
  // The runs read for the memory_limit check at the start, for the ingest.
  std::optional<JobData> loaded;

  std::string Work(const std::string& name) const { return (fs::path(work) / name).string(); }
  std::string Output(const std::string& name) const {
    return (fs::path(spec.output) / name).string();
  }
  // A plain line on stderr (unless quiet) and the same event in log.jsonl.
  void Info(const std::string& stage, const std::string& message, json extra = json::object()) {
    if (!quiet) {
      if (display) display->Finish();
      std::fprintf(stderr, "graphslam run: [%s] %s\n", stage.c_str(), message.c_str());
    }
    extra["event"] = "info";
    extra["stage"] = stage;
    extra["message"] = message;
    log.Write(std::move(extra));
  }
};

bool Exists(const std::string& path) { return storage::Env::Default()->FileExists(path); }

Status ReadJson(const std::string& path, json* out) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(
                          storage::Env::Default(), path,
                          path + ": missing (was the stage before it completed?)"));
  *out = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (out->is_discarded()) return Status::Corruption(path + ": not valid JSON");
  return Status::Ok();
}

Status WriteJson(const std::string& path, const json& value) {
  return storage::WriteStringAtomically(storage::Env::Default(), path, value.dump(1) + "\n");
}

// ---- runs.json: everything of JobData but the problem ----------------------

json RunsToJson(const JobData& data) {
  json runs = json::array();
  for (const RunInfo& run : data.runs) {
    runs.push_back({{"name", run.name},
                    {"first_pose", run.first_pose},
                    {"num_poses", run.num_poses},
                    {"component", run.component},
                    {"gps_fixes", run.gps_fixes},
                    {"has_ground_truth", run.has_ground_truth},
                    {"synthetic_time", run.synthetic_time},
                    {"information_repairs", run.information_repairs.count},
                    {"information_repair_lines", run.information_repairs.first_lines},
                    {"unidentified", run.unidentified},
                    {"indoor", run.indoor},
                    {"unknown_barcodes_skipped", run.unknown_barcodes_skipped},
                    {"unknown_barcode_lines", run.unknown_barcode_lines}});
  }
  json truth = json::object();
  for (const auto& [name, poses] : data.ground_truth) {
    json list = json::array();
    for (const StampedPose2& p : poses)
      list.push_back({p.stamp, p.pose.x(), p.pose.y(), p.pose.z()});
    truth[name] = list;
  }
  json features = json::array();
  for (const auto& [id, point] : data.ground_truth_features)
    features.push_back({id, point.x(), point.y()});
  json origin = nullptr;
  if (data.enu_origin) origin = {(*data.enu_origin)[0], (*data.enu_origin)[1], (*data.enu_origin)[2]};
  return {{"runs", runs},
          {"num_components", data.num_components},
          {"ground_truth", truth},
          {"ground_truth_features", features},
          {"enu_origin", origin},
          {"robot_sightings",
           {{"constraints", data.sightings.constraints},
            {"interpolated", data.sightings.interpolated},
            {"robot_not_in_job", data.sightings.robot_not_in_job},
            {"no_pose_at_stamp", data.sightings.no_pose_at_stamp},
            {"standstill_repeats_merged", data.sightings.standstill_repeats_merged}}}};
}

// The runs (and components) that go with a stage's problem: after data
// association tied runs together (associate stage), its associated_runs.json.
std::string RunsFileFor(const Context& ctx, const std::string& problem_file) {
  if (problem_file == "ingested.graphslam" || problem_file == "initialized.graphslam" ||
      problem_file == "optimized_without_gps.graphslam" ||
      !Exists(ctx.Work("associated_runs.json")))
    return "runs.json";
  return "associated_runs.json";
}

Status LoadData(const Context& ctx, const std::string& problem_file, JobData* data) {
  json runs;
  const std::string runs_file = RunsFileFor(ctx, problem_file);
  GS_RETURN_IF_ERROR(ReadJson(ctx.Work(runs_file), &runs));
  try {
    data->runs.clear();
    for (const json& r : runs.at("runs")) {
      RunInfo run;
      run.name = r.at("name").get<std::string>();
      run.first_pose = r.at("first_pose").get<int32_t>();
      run.num_poses = r.at("num_poses").get<int32_t>();
      run.component = r.at("component").get<int32_t>();
      run.gps_fixes = r.at("gps_fixes").get<int64_t>();
      run.has_ground_truth = r.at("has_ground_truth").get<bool>();
      run.synthetic_time = r.value("synthetic_time", false);
      run.information_repairs.count = r.value("information_repairs", int64_t{0});
      run.information_repairs.first_lines =
          r.value("information_repair_lines", std::vector<int32_t>());
      run.unidentified = r.value("unidentified", false);
      run.indoor = r.at("indoor").get<std::vector<uint8_t>>();
      run.unknown_barcodes_skipped = r.value("unknown_barcodes_skipped", int64_t{0});
      run.unknown_barcode_lines =
          r.value("unknown_barcode_lines", std::vector<std::string>());
      data->runs.push_back(std::move(run));
    }
    data->num_components = runs.at("num_components").get<int32_t>();
    for (const auto& [name, list] : runs.at("ground_truth").items()) {
      std::vector<StampedPose2>& poses = data->ground_truth[name];
      for (const json& p : list) {
        StampedPose2 pose;
        pose.stamp = p.at(0).get<double>();
        pose.pose = core::Pose2(p.at(1).get<double>(), p.at(2).get<double>(), p.at(3).get<double>());
        poses.push_back(pose);
      }
    }
    for (const json& f : runs.at("ground_truth_features"))
      data->ground_truth_features[f.at(0).get<int64_t>()] =
          core::Point2(f.at(1).get<double>(), f.at(2).get<double>());
    if (!runs.at("enu_origin").is_null())
      data->enu_origin = runs.at("enu_origin").get<std::array<double, 3>>();
    if (runs.contains("robot_sightings")) {
      const json& sightings = runs.at("robot_sightings");
      data->sightings.constraints = sightings.at("constraints").get<int64_t>();
      data->sightings.interpolated = sightings.value("interpolated", int64_t{0});
      data->sightings.robot_not_in_job = sightings.at("robot_not_in_job").get<int64_t>();
      data->sightings.no_pose_at_stamp = sightings.at("no_pose_at_stamp").get<int64_t>();
      data->sightings.standstill_repeats_merged =
          sightings.value("standstill_repeats_merged", int64_t{0});
    }
  } catch (const json::exception& error) {
    return Status::Corruption(ctx.Work(runs_file) + ": " + error.what());
  }
  StatusOr<core::Problem2d> problem = storage::ReadNativeLog(ctx.Work(problem_file));
  if (!problem.ok()) return problem.status();
  data->problem = std::move(problem).value();
  int64_t poses = 0;
  for (const RunInfo& run : data->runs) poses += run.num_poses;
  if (poses != data->problem.num_poses())
    return Status::Corruption(ctx.Work(problem_file) + ": " +
                              std::to_string(data->problem.num_poses()) + " poses; expected " +
                              std::to_string(poses) + " (" + runs_file + ")");
  return Status::Ok();
}

// ---- solver settings shared by initialize and optimize ----------------------

// The job file's solver settings through the application layer
// (tools/pipeline/solve_request.h), as `graphslam solve` builds its own.
// Under memory_limit the CHOLMOD factor gets what the limit leaves beside
// the problem (tools/job/job_memory_budget.h).
StatusOr<core::SolverOptions> SolverOptionsFor(const JobSpec& spec,
                                               const core::Problem2d& problem) {
  SolverSettings settings;
  settings.linear_solver = spec.solver.linear_solver;
  settings.robust_kernel = spec.solver.robust_kernel;
  settings.max_iterations = spec.solver.max_iterations;
  settings.function_tolerance = spec.solver.function_tolerance;
  settings.model_tolerance = spec.solver.model_tolerance;
  StatusOr<core::SolverOptions> options = MakeSolverOptions(
      settings, {"solver.linear_solver", "solver.preconditioner", "solver.robust_kernel"});
  if (!options.ok()) return options.status().WithContext(spec.path);
  // A robot's barcode is read by the same camera as a landmark's: robot
  // sightings get the same kernel (misreads happen to both).
  options->pose_kernels.robot = options->observation_kernel;
  if (spec.memory_limit > 0) {
    const JobSize size = JobSizeOf(spec, problem);
    GS_ASSIGN_OR_RETURN(const JobBudget budget, BudgetJob(spec.memory_limit, size));
    options->auto_cholmod_max_factor_bytes = std::min(
        options->auto_cholmod_max_factor_bytes, budget.spare_bytes / kCholmodBytesPerFactorByte);
    if (options->linear_solver == core::LinearSolverType::kCholmod)
      options->cholmod_factor_check = [limit = spec.memory_limit, size](double factor_bytes) {
        return CheckJobCholmodFactor(limit, size, factor_bytes);
      };
  }
  return options;
}

// Table 1 and (optionally) incremental or progressive initialization of every
// component.
Status InitializeComponents(const JobSpec& spec, const core::SolverOptions& base,
                            ProgressDisplay* display, JobData* data) {
  for (int32_t c = 0; c < data->num_components; ++c) {
    std::vector<int32_t> pose_map, feature_map;
    core::Problem2d sub = ExtractComponent(*data, c, &pose_map, &feature_map);
    GS_RETURN_IF_ERROR(core::InitializeProblem(&sub));
    AlignRunFrames(*data, c, &sub);
    core::SolverOptions options = base;
    if (display) options.progress = display->AsCallback();
    partition::ProgressiveInitializationOptions progressive;
    progressive.enabled = spec.solver.initialization == "progressive";
    partition::ProgressiveSummary summary;
    GS_RETURN_IF_ERROR(partition::InitializeProgressively(progressive, options, &sub, &summary));
    partition::IncrementalInitializationOptions incremental;
    incremental.enabled =
        spec.solver.initialization == "auto" || spec.solver.initialization == "incremental";
    partition::IncrementalSummary incremental_summary;
    GS_RETURN_IF_ERROR(
        partition::InitializeIncrementally(incremental, options, &sub, &incremental_summary));
    ScatterComponent(sub, pose_map, feature_map, &data->problem);
  }
  return Status::Ok();
}

// ---- stages -----------------------------------------------------------------

Status StageIngest(Context& ctx) {
  StatusOr<JobData> loaded = ctx.loaded ? std::move(*ctx.loaded) : LoadJobData(ctx.spec);
  ctx.loaded.reset();
  if (!loaded.ok()) return loaded.status();
  const JobData& data = *loaded;
  for (const RunInfo& run : data.runs) {
    ctx.Info("ingest",
             "run " + run.name + ": " + std::to_string(run.num_poses) + " poses, " +
                 std::to_string(run.gps_fixes) + " GPS fixes, component " +
                 std::to_string(run.component),
             {{"run", run.name}, {"poses", run.num_poses}, {"gps_fixes", run.gps_fixes}});
    if (run.unknown_barcodes_skipped > 0)
      ctx.Info("ingest",
               "run " + run.name + ": warning: " + std::to_string(run.unknown_barcodes_skipped) +
                   " measurements with a barcode in no row of Barcodes.dat skipped (first: " +
                   run.unknown_barcode_lines.front() + ")",
               {{"run", run.name}, {"unknown_barcodes_skipped", run.unknown_barcodes_skipped}});
  }
  if (data.sightings.constraints + data.sightings.robot_not_in_job +
          data.sightings.no_pose_at_stamp > 0)
    ctx.Info("ingest",
             "robot sightings: " + std::to_string(data.sightings.constraints) +
                 " robot-to-robot constraints (" + std::to_string(data.sightings.interpolated) +
                 " interpolated); dropped " +
                 std::to_string(data.sightings.robot_not_in_job) + " of robots not in the job, " +
                 std::to_string(data.sightings.no_pose_at_stamp) + " without a pose at their stamp",
             {{"robot_sighting_constraints", data.sightings.constraints}});
  GS_RETURN_IF_ERROR(storage::WriteNativeLog(data.problem, ctx.Work("ingested.graphslam")));
  // Scans of simulated runs, generated now into disk-backed scan chunks.
  StatusOr<int64_t> scans = WriteSimulatedScans(ctx.spec, data, ctx.work);
  if (!scans.ok()) return scans.status();
  if (*scans > 0)
    ctx.Info("ingest", "wrote " + std::to_string(*scans) + " laser scans into " +
                           ctx.Work("scans/"),
             {{"scans", *scans}});
  return WriteJson(ctx.Work("runs.json"), RunsToJson(data));
}

Status StageInitialize(Context& ctx) {
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx, "ingested.graphslam", &data));
  StatusOr<core::SolverOptions> base = SolverOptionsFor(ctx.spec, data.problem);
  if (!base.ok()) return base.status();
  GS_RETURN_IF_ERROR(InitializeComponents(ctx.spec, *base, ctx.display.get(), &data));
  return storage::WriteNativeLog(data.problem, ctx.Work("initialized.graphslam"));
}

// Unknown correspondences (runs with ids: false or without feature ids):
// GraphSLAM with data association (Table 10, partition/association/association_driver.h)
// over all runs at once, starting from the initialized guesses; merged
// landmarks tie runs, so the components are found again.
//   -> .job/associated.graphslam, .job/associated_runs.json, .job/associate.json
Status AssociateUnknown(Context& ctx) {
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx, "initialized.graphslam", &data));
  const int32_t components_before = data.num_components;
  StatusOr<core::SolverOptions> base = SolverOptionsFor(ctx.spec, data.problem);
  if (!base.ok()) return base.status();
  core::SolverOptions solver = *base;
  if (ctx.display) solver.progress = ctx.display->AsCallback();
  partition::AssociationOptions options;
  partition::AssociationSummary summary;
  GS_RETURN_IF_ERROR(partition::AssociateAndSolve(options, solver, &data.problem, &summary));
  UpdateComponents(&data);
  ctx.Info("associate",
           "data association: " + std::to_string(summary.initial_features) + " -> " +
               std::to_string(summary.final_features) + " landmarks (" +
               std::to_string(summary.merges) + " merges, " + std::to_string(summary.undone) +
               " undone, " + std::to_string(summary.rounds.size()) + " rounds); components " +
               std::to_string(components_before) + " -> " + std::to_string(data.num_components),
           {{"initial_features", summary.initial_features},
            {"final_features", summary.final_features},
            {"merges", summary.merges},
            {"undone", summary.undone},
            {"rounds", static_cast<int64_t>(summary.rounds.size())},
            {"components_before", components_before},
            {"components_after", data.num_components}});
  GS_RETURN_IF_ERROR(storage::WriteNativeLog(data.problem, ctx.Work("associated.graphslam")));
  GS_RETURN_IF_ERROR(WriteJson(ctx.Work("associate.json"),
                               {{"initial_features", summary.initial_features},
                                {"final_features", summary.final_features},
                                {"merges", summary.merges},
                                {"undone", summary.undone},
                                {"rounds", static_cast<int64_t>(summary.rounds.size())},
                                {"converged", summary.converged},
                                {"components_before", components_before},
                                {"components_after", data.num_components}}));
  // Last: its presence says associated.graphslam is complete.
  return WriteJson(ctx.Work("associated_runs.json"), RunsToJson(data));
}

Status StageAssociate(Context& ctx) {
  {
    JobData ingested;
    GS_RETURN_IF_ERROR(LoadData(ctx, "ingested.graphslam", &ingested));
    for (const RunInfo& run : ingested.runs)
      if (run.unidentified) return AssociateUnknown(ctx);
  }
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx, "ingested.graphslam", &data));
  // Landmarks seen by more than one run tie the runs (known correspondences).
  std::vector<int32_t> first_run(static_cast<size_t>(data.problem.num_features()), -1);
  std::vector<uint8_t> shared(first_run.size(), 0);
  std::vector<int32_t> run_of_pose(static_cast<size_t>(data.problem.num_poses()));
  for (size_t r = 0; r < data.runs.size(); ++r)
    for (int32_t i = 0; i < data.runs[r].num_poses; ++i)
      run_of_pose[static_cast<size_t>(data.runs[r].first_pose + i)] = static_cast<int32_t>(r);
  for (const core::Observation& o : data.problem.observations) {
    int32_t& first = first_run[static_cast<size_t>(o.feature)];
    const int32_t run = run_of_pose[static_cast<size_t>(o.pose)];
    if (first < 0) first = run;
    else if (first != run) shared[static_cast<size_t>(o.feature)] = 1;
  }
  const auto count = std::count(shared.begin(), shared.end(), 1);
  ctx.Info("associate",
           "known correspondences (landmark ids): " + std::to_string(count) +
               " landmarks are seen by more than one run",
           {{"shared_landmarks", count}});
  return Status::Ok();
}

// Every iteration's damping and whether its step was taken, for the report's
// convergence plots (iterations before a resume keep only their chi2).
void RecordIterations(const std::vector<core::IterationSummary>& iterations, json* history) {
  for (const core::IterationSummary& it : iterations) {
    const json entry = {{"iteration", it.iteration}, {"chi2", it.chi2}, {"lambda", it.lambda},
                        {"accepted", it.accepted}, {"candidate_chi2", it.candidate_chi2}};
    auto same = std::find_if(history->begin(), history->end(), [&](const json& h) {
      return h.value("iteration", 0) == it.iteration;
    });
    if (same != history->end()) *same = entry;
    else history->push_back(entry);
  }
}

// The runs of component c: their names (a JSON list and one line) and GPS fixes.
struct ComponentRuns {
  json names = json::array();
  std::string line;
  int64_t gps_fixes = 0;
};
ComponentRuns RunsOfComponent(const JobData& data, int32_t c) {
  ComponentRuns runs;
  for (const RunInfo& run : data.runs) {
    if (run.component != c) continue;
    runs.names.push_back(run.name);
    runs.gps_fixes += run.gps_fixes;
    runs.line += (runs.line.empty() ? "" : ", ") + run.name;
  }
  return runs;
}

// One component's checkpoint, its chi2 history beside it, and the input
// name the checkpoint is bound to.
struct ComponentFiles {
  std::string checkpoint;
  std::string history;
  std::string input;
};
ComponentFiles FilesOfComponent(const Context& ctx, int32_t c) {
  // Not "c" + std::to_string(c): a GCC 12 -Wrestrict false positive here.
  const std::string tag = std::string("c").append(std::to_string(c));
  return {ctx.Work("optimize_" + tag + ".checkpoint.json"),
          ctx.Work("optimize_" + tag + ".history.json"),
          ctx.spec.path + "#component" + std::to_string(c)};
}

// With a checkpoint of component c: *resume_state from it, and the history
// up to its iteration (the history is written before the checkpoint).
Status ResumeComponent(Context& ctx, int32_t c, const ComponentFiles& files,
                       core::SolverCheckpoint* resume_state, json* history) {
  StatusOr<core::SolverCheckpoint> read =
      storage::ReadSolverCheckpoint(files.checkpoint, files.input);
  if (!read.ok()) return read.status();
  *resume_state = std::move(read).value();
  json stored;
  if (ReadJson(files.history, &stored).ok() && stored.is_array()) {
    for (const json& h : stored)
      if (h.value("iteration", 0) <= resume_state->iterations) history->push_back(h);
  }
  ctx.Info("optimize", "component " + std::to_string(c) + ": resuming after iteration " +
                           std::to_string(resume_state->iterations),
           {{"component", c}, {"resumed_from_iteration", resume_state->iterations}});
  return Status::Ok();
}

// optimize.json's entry of one solved component.
json ComponentReport(int32_t c, const ComponentRuns& runs, const core::Problem2d& sub,
                     const core::SolverSummary& summary, const json& history) {
  return {{"component", c},
          {"runs", runs.names},
          {"poses", sub.num_poses()},
          {"features", sub.num_features()},
          {"gps_fixes", runs.gps_fixes},
          {"iterations", summary.iterations},
          {"initial_chi2", summary.initial_chi2},
          {"final_chi2", summary.final_chi2},
          {"converged", summary.converged},
          {"termination", summary.termination},
          {"linear_solver", core::LinearSolverName(summary.linear_solver_used)},
          {"excluded_features", summary.excluded_features},
          {"history", history}};
}

// Solves component c of *data in place; with `checkpoints`, it continues
// from / writes .job/optimize_c<k>.checkpoint.json and its chi2 history.
// Returns its entry of optimize.json; its features' excluded flags go into
// *excluded.
StatusOr<json> SolveComponent(Context& ctx, bool checkpoints, int32_t c,
                              const core::SolverOptions& base, JobData* data,
                              std::vector<uint8_t>* excluded) {
  std::vector<int32_t> pose_map, feature_map;
  core::Problem2d sub = ExtractComponent(*data, c, &pose_map, &feature_map);
  partition::ChunkingOptions chunking;
  partition::InMemoryChunkSource chunks(sub, chunking);
  const ComponentRuns runs = RunsOfComponent(*data, c);
  core::SolverOptions options = base;
  if (ctx.display) {
    // Names which solve runs: a job solves each component, and again
    // without GPS when asked.
    ctx.display->SetContext("optimize " + runs.line +
                            (data->problem.gps.empty() ? " (no GPS)" : " (with GPS)"));
    options.progress = ctx.display->AsCallback();
    options.iteration_callback = ctx.display->AsIterationCallback();
  }
  const ComponentFiles files = FilesOfComponent(ctx, c);
  core::SolverCheckpoint resume_state;
  json history = json::array();
  if (checkpoints && Exists(files.checkpoint)) {
    GS_RETURN_IF_ERROR(ResumeComponent(ctx, c, files, &resume_state, &history));
    options.resume_from = &resume_state;
  }
  if (checkpoints) {
    options.checkpoint_callback = [&](const core::SolverCheckpoint& checkpoint) -> Status {
      // The history has a row per iteration; the start's checkpoint
      // (iteration 0) is not one.
      if (checkpoint.iterations > 0) {
        history.push_back({{"iteration", checkpoint.iterations}, {"chi2", checkpoint.chi2}});
        GS_RETURN_IF_ERROR(WriteJson(files.history, history));
      }
      return storage::WriteSolverCheckpoint(storage::Env::Default(), files.checkpoint,
                                            files.input, checkpoint);
    };
  }
  core::SolverSummary summary;
  GS_RETURN_IF_ERROR(core::SolveGraphSlam(options, chunks, &sub, &summary));
  if (ctx.display) {
    ctx.display->Finish();
    ctx.display->SetContext("");
  }
  ScatterComponent(sub, pose_map, feature_map, &data->problem);
  for (size_t f = 0; f < feature_map.size(); ++f)
    (*excluded)[static_cast<size_t>(feature_map[f])] = summary.excluded[f];
  RecordIterations(summary.per_iteration, &history);
  ctx.Info("optimize",
           "component " + std::to_string(c) + ": " + std::to_string(summary.iterations) +
               " iterations, chi2 " + std::to_string(summary.initial_chi2) + " -> " +
               std::to_string(summary.final_chi2) + " (" + summary.termination + ")",
           {{"component", c}, {"final_chi2", summary.final_chi2}});
  return ComponentReport(c, runs, sub, summary, history);
}

// Solves every component of `data` (SolveComponent), their entries into
// *components.
Status SolveComponents(Context& ctx, bool checkpoints, JobData* data, json* components,
                       std::vector<uint8_t>* excluded) {
  StatusOr<core::SolverOptions> base = SolverOptionsFor(ctx.spec, data->problem);
  if (!base.ok()) return base.status();
  excluded->assign(static_cast<size_t>(data->problem.num_features()), 1);  // unobserved: 1
  *components = json::array();
  for (int32_t c = 0; c < data->num_components; ++c) {
    GS_ASSIGN_OR_RETURN(json entry, SolveComponent(ctx, checkpoints, c, *base, data, excluded));
    components->push_back(std::move(entry));
  }
  return Status::Ok();
}

Status StageOptimize(Context& ctx) {
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx,
                              Exists(ctx.Work("associated_runs.json")) ? "associated.graphslam"
                                                                            : "initialized.graphslam",
                              &data));
  json components;
  std::vector<uint8_t> excluded;
  GS_RETURN_IF_ERROR(SolveComponents(ctx, /*checkpoints=*/true, &data, &components, &excluded));
  if (ctx.spec.compare_without_gps && !data.problem.gps.empty()) {
    // The ablation: the same job without any GPS fix, from the same inputs.
    ctx.Info("optimize", "solving again without GPS (compare_without_gps)");
    JobData without;
    GS_RETURN_IF_ERROR(LoadData(ctx, "ingested.graphslam", &without));
    RemoveGps(&without);
    StatusOr<core::SolverOptions> base = SolverOptionsFor(ctx.spec, without.problem);
    if (!base.ok()) return base.status();
    GS_RETURN_IF_ERROR(InitializeComponents(ctx.spec, *base, ctx.display.get(), &without));
    json ignored;
    std::vector<uint8_t> ignored_excluded;
    GS_RETURN_IF_ERROR(SolveComponents(ctx, false, &without, &ignored, &ignored_excluded));
    GS_RETURN_IF_ERROR(
        storage::WriteNativeLog(without.problem, ctx.Work("optimized_without_gps.graphslam")));
  }
  GS_RETURN_IF_ERROR(storage::WriteNativeLog(data.problem, ctx.Work("optimized.graphslam")));
  return WriteJson(ctx.Work("optimize.json"), {{"components", components}, {"excluded", excluded}});
}

Status StageMap(Context& ctx) {
  if (!JobHasScans(ctx.spec, ctx.work)) {
    ctx.Info("map", "map stage: no scans");
    return Status::Ok();
  }
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx, "optimized.graphslam", &data));
  StatusOr<json> summary = BuildJobMap(ctx.spec, data, ctx.work, ctx.display.get());
  if (!summary.ok()) return summary.status();
  ctx.Info("map",
           "fused " + std::to_string((*summary)["scans"].get<int64_t>()) + " scans (" +
               std::to_string((*summary)["points"].get<int64_t>()) + " points) into " +
               std::to_string((*summary)["occupied_leaves"].get<int64_t>()) +
               " occupied cells; " + std::to_string((*summary)["pcd_points"].get<int64_t>()) +
               " points in map.pcd",
           *summary);
  return Status::Ok();
}

// ---- export -------------------------------------------------------------------

// The report's stage table: time and memory of every stage, the export's so far.
json StagesReport(const Context& ctx, Clock::time_point export_start, bool has_map) {
  json stages = json::array();
  for (Stage stage : ctx.spec.stages) {
    const std::string name = StageName(stage);
    const CompletedStage* done = ctx.state.Find(name);
    double seconds = 0;
    int64_t rss = 0;
    if (done != nullptr) {
      seconds = done->seconds;
      rss = done->peak_rss_bytes;
    } else if (stage == Stage::kExport) {
      seconds = std::chrono::duration<double>(Clock::now() - export_start).count();
      rss = PeakRssBytes();
    }
    json entry = {{"stage", name}, {"seconds", seconds}, {"peak_rss_bytes", rss}};
    if (stage == Stage::kMap) entry["note"] = has_map ? "scans fused" : "no scans";
    stages.push_back(entry);
  }
  return stages;
}

// optimize.json's `excluded`: one flag per feature of `data`.
StatusOr<std::vector<uint8_t>> ExcludedFeatures(const Context& ctx, const json& optimize,
                                                const JobData& data) {
  std::vector<uint8_t> excluded = optimize.value("excluded", std::vector<uint8_t>());
  if (excluded.size() != static_cast<size_t>(data.problem.num_features()))
    return Status::Corruption(ctx.Work("optimize.json") + ": 'excluded' has " +
                              std::to_string(excluded.size()) + " entries; expected " +
                              std::to_string(data.problem.num_features()));
  return excluded;
}

// The map (map stage): its files copied atomically, with their run name
// tables, and its summary (null without a map).
StatusOr<json> ExportMap(const Context& ctx, const JobData& data,
                         std::vector<std::string>* map_files) {
  if (!ctx.spec.HasStage(Stage::kMap) || !Exists(ctx.Work("map.json"))) return json(nullptr);
  json summary;
  GS_RETURN_IF_ERROR(ReadJson(ctx.Work("map.json"), &summary));
  GS_ASSIGN_OR_RETURN(*map_files, ExportJobMap(ctx.work, ctx.spec.output));
  GS_ASSIGN_OR_RETURN(std::vector<std::string> tables,
                      WriteMapRunNames(data, ctx.spec.output, *map_files));
  map_files->insert(map_files->end(), tables.begin(), tables.end());
  return summary;
}

// report.json's keys beyond the runs (tools/job/job_export.h has the steps).
Status AddJobReport(Context& ctx, const JobData& data, const std::vector<uint8_t>& excluded,
                    const ErrorSums& sums, json* report) {
  if (json sightings = RobotSightingsReport(data); !sightings.is_null())
    (*report)["robot_sightings"] = sightings;
  if (Exists(ctx.Work("associate.json"))) {
    json association;
    GS_RETURN_IF_ERROR(ReadJson(ctx.Work("associate.json"), &association));
    (*report)["association"] = association;
  }
  if (sums.all_count > 0) (*report)["position_rmse_m"] = Rmse(sums.all_sum, sums.all_count);
  if (data.enu_origin)
    (*report)["enu_origin"] = {{"latitude", (*data.enu_origin)[0]},
                               {"longitude", (*data.enu_origin)[1]},
                               {"height", (*data.enu_origin)[2]}};
  if (!data.ground_truth_features.empty())
    (*report)["features"] = FeatureErrorsReport(data, excluded);
  // GPS ablation (Figure 6).
  if (Exists(ctx.Work("optimized_without_gps.graphslam"))) {
    JobData without;
    GS_RETURN_IF_ERROR(LoadData(ctx, "optimized_without_gps.graphslam", &without));
    const ErrorSums w = SumRunErrors(without);
    (*report)["gps_comparison"] = {
        {"indoor_poses", sums.indoor_count},
        {"indoor_rmse_with_gps_m", Rmse(sums.indoor_sum, sums.indoor_count)},
        {"indoor_rmse_without_gps_m", Rmse(w.indoor_sum, w.indoor_count)},
        {"position_rmse_with_gps_m", Rmse(sums.all_sum, sums.all_count)},
        {"position_rmse_without_gps_m", Rmse(w.all_sum, w.all_count)}};
  }
  return Status::Ok();
}

// The report's map picture reads every point of the map's .pcd files: under
// memory_limit it is left out, with a warning, when they do not fit in what
// the limit leaves beside the problem (tools/job/job_memory_budget.h).
StatusOr<bool> MapPictureFits(const Context& ctx, const JobData& data, const json& map_summary,
                              json* warnings) {
  if (ctx.spec.memory_limit <= 0 || map_summary.is_null()) return true;
  int64_t points = 0;
  for (const json& map : map_summary.value("maps", json::array()))
    points += map.value("pcd_points", int64_t{0});
  GS_ASSIGN_OR_RETURN(const JobBudget budget,
                      BudgetJob(ctx.spec.memory_limit, JobSizeOf(ctx.spec, data.problem)));
  const int64_t bytes = points * kJobMapPictureBytesPerPoint;
  if (bytes <= budget.spare_bytes) return true;
  warnings->push_back("the report's map picture is left out: its " + std::to_string(points) +
                      " points need " + FormatBytes(bytes) + ", more than the memory limit " +
                      "leaves beside the problem (" + FormatBytes(budget.spare_bytes) + ")");
  return false;
}

Status StageExport(Context& ctx, const Clock::time_point export_start) {
  JobData data;
  GS_RETURN_IF_ERROR(LoadData(ctx, "optimized.graphslam", &data));
  json optimize;
  GS_RETURN_IF_ERROR(ReadJson(ctx.Work("optimize.json"), &optimize));
  GS_ASSIGN_OR_RETURN(const std::vector<uint8_t> excluded, ExcludedFeatures(ctx, optimize, data));
  GS_RETURN_IF_ERROR(WriteRunTrajectories(data, ctx.spec.output));

  json report;
  report["job"] = ctx.spec.path;
  report["output"] = ctx.spec.output;
  report["threads"] = ctx.spec.threads > 0 ? ctx.spec.threads : tbb::info::default_concurrency();
  report["memory_limit_bytes"] = ctx.spec.memory_limit;
  json warnings = json::array();
  const RunsReport runs = ReportRuns(data, &warnings);
  report["runs"] = runs.runs;
  report["joint_trajectory_errors"] = runs.joint_trajectory_errors;
  report["components"] = optimize["components"];
  GS_RETURN_IF_ERROR(AddJobReport(ctx, data, excluded, runs.sums, &report));
  std::vector<std::string> map_files;
  GS_ASSIGN_OR_RETURN(const json map_summary, ExportMap(ctx, data, &map_files));

  report["stages"] = StagesReport(ctx, export_start, !map_summary.is_null());
  GS_ASSIGN_OR_RETURN(const bool map_picture, MapPictureFits(ctx, data, map_summary, &warnings));
  if (ctx.spec.memory_limit > 0 && PeakRssBytes() > ctx.spec.memory_limit)
    warnings.push_back("peak resident memory " + std::to_string(PeakRssBytes() >> 20) +
                       " MiB exceeded the memory limit of " +
                       std::to_string(ctx.spec.memory_limit >> 20) + " MiB");
  report["warnings"] = warnings;
  report["outputs"] = {"trajectories/", "features.csv", "graph.g2o", "report.json", "report.html"};
  for (const std::string& file : map_files) report["outputs"].push_back(file);
  if (!map_summary.is_null()) report["map"] = map_summary;

  // Outputs, each atomically.
  GS_RETURN_IF_ERROR(storage::WriteFeaturesCsv(data.problem, ctx.Output("features.csv"), &excluded));
  GS_RETURN_IF_ERROR(storage::WriteG2o(data.problem, ctx.Output("graph.g2o")));
  GS_RETURN_IF_ERROR(WriteJson(ctx.Output("report.json"), report));
  StatusOr<ReportInputs> report_inputs =
      CollectReportInputs(data, excluded, report, ctx.spec.output);
  if (!report_inputs.ok()) return report_inputs.status();
  if (!map_picture) report_inputs->map_pcds.clear();
  StatusOr<std::string> html = RenderReportHtml(report, *report_inputs);
  if (!html.ok()) return html.status();
  GS_RETURN_IF_ERROR(
      storage::WriteStringAtomically(storage::Env::Default(), ctx.Output("report.html"), *html));
  for (const json& w : warnings) ctx.Info("export", "warning: " + w.get<std::string>());
  std::string map_list;
  for (const std::string& file : map_files) map_list += ", " + file;
  ctx.Info("export", "wrote " + ctx.spec.output + " (trajectories/, features.csv, graph.g2o" +
                         map_list + ", report.json, report.html)");
  return Status::Ok();
}

Status RunStage(Context& ctx, Stage stage, Clock::time_point start) {
  switch (stage) {
    case Stage::kIngest: return StageIngest(ctx);
    case Stage::kInitialize: return StageInitialize(ctx);
    case Stage::kAssociate: return StageAssociate(ctx);
    case Stage::kOptimize: return StageOptimize(ctx);
    case Stage::kMap: return StageMap(ctx);
    case Stage::kExport: return StageExport(ctx, start);
  }
  return Status::InvalidArgument("unknown stage");
}

// Removes the temporaries (storage/atomic_file.h "NAME.tmp-PID") a killed
// job left: anywhere in OUTPUT/.job/ (ours), and in OUTPUT/ and
// OUTPUT/trajectories/ only those of the files the export stage writes.
Status RemoveStaleJobTemporaries(const std::string& output, const std::string& work) {
  GS_RETURN_IF_ERROR(storage::RemoveStaleTemporaries(storage::Env::Default(), work, true));
  static const std::vector<std::string> kExports = {"features.csv", "graph.g2o", "report.json",
                                                    "report.html"};
  storage::Env* env = storage::Env::Default();
  for (const fs::path& folder : {fs::path(output), fs::path(output) / "trajectories"}) {
    if (env->KindOf(folder.string()) != storage::FileKind::kDirectory) continue;
    GS_ASSIGN_OR_RETURN(const std::vector<std::string> names, env->ListDir(folder.string()));
    for (const std::string& name : names) {
      const std::string path = (folder / name).string();
      if (!storage::IsTemporaryFileName(name) || env->KindOf(path) != storage::FileKind::kRegular)
        continue;
      const std::string base = name.substr(0, name.rfind(".tmp-"));
      const bool ours = folder.filename() == "trajectories"
                            ? base.size() > 4 && base.compare(base.size() - 4, 4, ".tum") == 0
                            : std::find(kExports.begin(), kExports.end(), base) != kExports.end();
      if (ours) GS_RETURN_IF_ERROR(env->RemoveFile(path));
    }
  }
  return Status::Ok();
}

// memory_limit: the job's need (tools/job/job_memory_budget.h) from its
// runs, read or simulated now and kept for the ingest stage, or, resuming
// after the ingest, from its result. A limit below the need is refused
// before the job writes anything (InvalidArgument: exit 2).
Status CheckMemoryLimit(Context& ctx, bool after_ingest) {
  if (ctx.spec.memory_limit <= 0) return Status::Ok();
  if (after_ingest) {
    GS_ASSIGN_OR_RETURN(const core::Problem2d problem,
                        storage::ReadNativeLog(ctx.Work("ingested.graphslam")));
    return BudgetJob(ctx.spec.memory_limit, JobSizeOf(ctx.spec, problem))
        .status()
        .WithContext(ctx.spec.path);
  }
  GS_ASSIGN_OR_RETURN(JobData data, LoadJobData(ctx.spec));
  GS_RETURN_IF_ERROR(BudgetJob(ctx.spec.memory_limit, JobSizeOf(ctx.spec, data.problem))
                         .status()
                         .WithContext(ctx.spec.path));
  ctx.loaded = std::move(data);
  return Status::Ok();
}

// The job file (spec, fingerprint) and its output folder (-o wins over the
// file's `output`), into *ctx.
Status LoadJob(const RunJobOptions& options, Context* ctx) {
  StatusOr<JobSpec> spec = ReadJobSpec(options.job_path);
  if (!spec.ok()) return spec.status();
  ctx->spec = std::move(spec).value();
  if (!options.output.empty())
    ctx->spec.output = fs::absolute(options.output).lexically_normal().string();
  if (ctx->spec.output.empty())
    return Status::InvalidArgument(options.job_path +
                                   ": no 'output' and no -o; expected output: <folder> in the job "
                                   "file or graphslam run -o DIR");
  ctx->quiet = options.quiet;
  GS_ASSIGN_OR_RETURN(const std::string job_text,
                      storage::ReadFileToString(storage::Env::Default(), options.job_path));
  ctx->fingerprint = Fingerprint(job_text);
  ctx->work = (fs::path(ctx->spec.output) / ".job").string();
  return Status::Ok();
}

// The stages to run, in order. Stages need their predecessors' results:
// ingest -> initialize -> optimize -> export form a chain, so a later one
// pulls in the earlier ones; associate and map run only when chosen.
std::vector<Stage> StagesToRun(const JobSpec& spec) {
  auto core_rank = [](Stage s) {
    switch (s) {
      case Stage::kIngest: return 0;
      case Stage::kInitialize: return 1;
      case Stage::kOptimize: return 2;
      case Stage::kExport: return 3;
      default: return -1;
    }
  };
  int last_core = -1;
  for (Stage s : spec.stages) last_core = std::max(last_core, core_rank(s));
  std::vector<Stage> stages;
  for (Stage stage : kAllStages)
    if (spec.HasStage(stage) || (core_rank(stage) >= 0 && core_rank(stage) <= last_core))
      stages.push_back(stage);
  return stages;
}

// Under the output folder's lock: with `resuming`, the state of the job that
// ran before (same job file, its stage results intact), else a fresh .job/.
Status OpenJobState(const RunJobOptions& options, bool resuming, const std::string& state_path,
                    Context* ctx) {
  if (resuming) {
    StatusOr<JobState> state = ReadJobState(state_path);
    if (!state.ok()) return state.status();
    if (state->job_fingerprint != ctx->fingerprint)
      return Status::InvalidArgument(
          options.job_path + ": the job file changed since " + state_path +
          " was written; run without --resume to start over");
    // The completed stages' results must be the bytes they wrote.
    GS_RETURN_IF_ERROR(VerifyJobFiles(ctx->work, *state));
    ctx->state = std::move(state).value();
    GS_RETURN_IF_ERROR(CheckMemoryLimit(*ctx, ctx->state.IsCompleted("ingest")));
  } else {
    // A fresh start: stage results of an earlier job go, its final outputs stay
    // until this job's export replaces them.
    GS_RETURN_IF_ERROR(storage::Env::Default()->RemoveTree(ctx->work));
    ctx->state.job_fingerprint = ctx->fingerprint;
  }
  GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir(ctx->work));
  return WriteJobState(state_path, ctx->state);
}

// Runs `stage` (the done + 1-th of total) and records it as completed, with
// the digests of the stage results, in state.json; logs start, failure, end.
Status RunAndRecordStage(Context& ctx, Stage stage, int64_t done, int64_t total,
                         const std::string& state_path) {
  const std::string name = StageName(stage);
  ctx.log.Write({{"event", "stage_start"}, {"stage", name}, {"done", done}, {"total", total}});
  storage::StopPointForTests("job_stage_start " + name);
  if (!ctx.quiet)
    ctx.Info(name, "stage " + std::to_string(done + 1) + "/" + std::to_string(total) + " started");
  const Clock::time_point start = Clock::now();
  if (Status status = RunStage(ctx, stage, start); !status.ok()) {
    ctx.log.Write({{"event", "stage_failed"}, {"stage", name}, {"error", status.ToString()}});
    return status;
  }
  CompletedStage completed;
  completed.stage = name;
  completed.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  completed.peak_rss_bytes = PeakRssBytes();
  ctx.state.completed.push_back(completed);
  StatusOr<std::map<std::string, FileDigest>> files = DigestJobFiles(ctx.work);
  if (!files.ok()) return files.status();
  ctx.state.files = std::move(files).value();
  GS_RETURN_IF_ERROR(WriteJobState(state_path, ctx.state));
  storage::StopPointForTests("job_stage_done " + name);
  ctx.display->Update("job", done + 1, total);
  ctx.log.Write({{"event", "stage_done"},
                 {"stage", name},
                 {"seconds", completed.seconds},
                 {"peak_rss_bytes", completed.peak_rss_bytes},
                 {"done", done + 1},
                 {"total", total}});
  return Status::Ok();
}

}  // namespace

Status RunJob(const RunJobOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  Context ctx;
  GS_RETURN_IF_ERROR(LoadJob(options, &ctx));
  const std::vector<Stage> stages = StagesToRun(ctx.spec);
  ctx.spec.stages = stages;
  const std::string state_path = ctx.Work("state.json");
  const bool resuming = options.resume && Exists(state_path);
  if (!resuming) GS_RETURN_IF_ERROR(CheckMemoryLimit(ctx, /*after_ingest=*/false));

  GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir(ctx.spec.output));
  // One job per output folder (storage/directory_lock.h): a second one fails
  // here, naming the holder's pid, before it touches anything.
  GS_ASSIGN_OR_RETURN(storage::DirectoryLock lock,
                      storage::DirectoryLock::Acquire(ctx.spec.output,
                                                      storage::DirectoryLock::Mode::kExclusive));
  // Under the lock, temporaries of our own files are those a killed job left.
  GS_RETURN_IF_ERROR(RemoveStaleJobTemporaries(ctx.spec.output, ctx.work));
  GS_RETURN_IF_ERROR(OpenJobState(options, resuming, state_path, &ctx));
  GS_RETURN_IF_ERROR(ctx.log.Open(ctx.Output("log.jsonl")));
  ctx.display = std::make_unique<ProgressDisplay>(!options.quiet);

  std::unique_ptr<tbb::global_control> threads;
  if (ctx.spec.threads > 0)
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    static_cast<size_t>(ctx.spec.threads));
  ctx.log.Write({{"event", "job_start"},
                 {"job", ctx.spec.path},
                 {"resume", options.resume},
                 {"stages", static_cast<int>(stages.size())}});
  const auto total = static_cast<int64_t>(stages.size());
  int64_t done = 0;
  for (Stage stage : stages) {
    const std::string name = StageName(stage);
    if (ctx.state.IsCompleted(name)) {
      ctx.Info(name, "already completed: skipped (--resume)");
    } else {
      GS_RETURN_IF_ERROR(RunAndRecordStage(ctx, stage, done, total, state_path));
    }
    ++done;
  }
  ctx.display->Finish();
  ctx.log.Write({{"event", "job_done"}});
  return Status::Ok();
}

}  // namespace graphslam::tools::job
