#include "tools/job/job_spec.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "storage/env.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

// "<file>:<line>:<column>: <message>" for `node` (yaml-cpp marks are 0-based).
Status Error(const std::string& file, const YAML::Node& node, const std::string& message) {
  const YAML::Mark mark = node.Mark();
  std::ostringstream out;
  out << file;
  if (mark.line >= 0) out << ":" << mark.line + 1 << ":" << mark.column + 1;
  out << ": " << message;
  return Status::InvalidArgument(out.str());
}

// yaml-cpp keeps both entries of a key given twice in one mapping, and
// node[key] finds the first: a duplicate would silently drop a setting. Every
// mapping of the tree is checked; the error names the second occurrence.
Status CheckDuplicateKeys(const std::string& file, const YAML::Node& node) {
  if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      const auto [it, inserted] = first_line.emplace(key, entry.first.Mark().line + 1);
      if (!inserted)
        return Error(file, entry.first,
                     "duplicate key '" + key + "' (first at line " + std::to_string(it->second) +
                         "); expected each key once per mapping");
      GS_RETURN_IF_ERROR(CheckDuplicateKeys(file, entry.second));
    }
  } else if (node.IsSequence()) {
    for (const auto& element : node) GS_RETURN_IF_ERROR(CheckDuplicateKeys(file, element));
  }
  return Status::Ok();
}

// A run's name names files (trajectories/<name>.tum, ...): a file name
// component of at most this many bytes (NAME_MAX is 255).
constexpr size_t kMaxRunNameBytes = 128;

// Reads scalars of the YAML tree with file:line errors.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  Status ExpectMap(const YAML::Node& node, const std::string& what,
                   const std::set<std::string>& keys) const {
    if (!node.IsMap()) return Error(file_, node, what + " must be a mapping; expected key: value");
    for (const auto& entry : node) {
      const std::string key = entry.first.Scalar();
      if (!keys.contains(key)) {
        std::string allowed;
        for (const std::string& k : keys) allowed += (allowed.empty() ? "" : ", ") + k;
        return Error(file_, entry.first,
                     "unknown key '" + key + "' in " + what + "; expected one of " + allowed);
      }
    }
    return Status::Ok();
  }

  Status String(const YAML::Node& node, const std::string& key, std::string* out) const {
    if (!node.IsScalar())
      return Error(file_, node, "'" + key + "' must be a single value; expected a string");
    *out = node.Scalar();
    return Status::Ok();
  }

  Status Double(const YAML::Node& node, const std::string& key, double* out) const {
    std::string text;
    GS_RETURN_IF_ERROR(String(node, key, &text));
    try {
      size_t used = 0;
      const double value = std::stod(text, &used);
      if (used != text.size() || !std::isfinite(value)) throw std::invalid_argument(text);
      *out = value;
    } catch (const std::exception&) {
      return Error(file_, node, "'" + key + "' is '" + text + "'; expected a finite number");
    }
    return Status::Ok();
  }

  Status Int(const YAML::Node& node, const std::string& key, int64_t min, int64_t max,
             int64_t* out) const {
    std::string text;
    GS_RETURN_IF_ERROR(String(node, key, &text));
    try {
      size_t used = 0;
      const long long value = std::stoll(text, &used);
      if (used != text.size()) throw std::invalid_argument(text);
      if (value < min || value > max) {
        return Error(file_, node, "'" + key + "' is " + text + "; expected an integer in [" +
                                      std::to_string(min) + ", " + std::to_string(max) + "]");
      }
      *out = value;
    } catch (const std::out_of_range&) {
      return Error(file_, node, "'" + key + "' is '" + text + "'; expected an integer");
    } catch (const std::invalid_argument&) {
      return Error(file_, node, "'" + key + "' is '" + text + "'; expected an integer");
    }
    return Status::Ok();
  }

  Status Int32(const YAML::Node& node, const std::string& key, int64_t min, int64_t max,
               int* out) const {
    int64_t value = 0;
    GS_RETURN_IF_ERROR(Int(node, key, min, max, &value));
    *out = static_cast<int>(value);
    return Status::Ok();
  }

  Status Bool(const YAML::Node& node, const std::string& key, bool* out) const {
    std::string text;
    GS_RETURN_IF_ERROR(String(node, key, &text));
    if (text == "true" || text == "yes" || text == "on") *out = true;
    else if (text == "false" || text == "no" || text == "off") *out = false;
    else return Error(file_, node, "'" + key + "' is '" + text + "'; expected true or false");
    return Status::Ok();
  }

  // "123", "4KiB", "512MiB", "2GiB" (also KB/MB/GB as powers of 1024).
  Status Bytes(const YAML::Node& node, const std::string& key, int64_t* out) const {
    std::string text;
    GS_RETURN_IF_ERROR(String(node, key, &text));
    size_t digits = 0;
    while (digits < text.size() &&
           (std::isdigit(static_cast<unsigned char>(text[digits])) || text[digits] == '.'))
      ++digits;
    std::string unit = text.substr(digits);
    double scale = 0;
    if (unit.empty() || unit == "B") scale = 1;
    else if (unit == "KiB" || unit == "KB" || unit == "K") scale = 1024.0;
    else if (unit == "MiB" || unit == "MB" || unit == "M") scale = 1024.0 * 1024;
    else if (unit == "GiB" || unit == "GB" || unit == "G") scale = 1024.0 * 1024 * 1024;
    double number = -1;
    try {
      if (digits > 0) number = std::stod(text.substr(0, digits));
    } catch (const std::exception&) {
    }
    if (scale == 0 || number < 0 || !std::isfinite(number * scale) || number * scale > 9e18)
      return Error(file_, node, "'" + key + "' is '" + text +
                                    "'; expected a size such as 512MiB, 2GiB or a byte count");
    *out = static_cast<int64_t>(number * scale);
    return Status::Ok();
  }

  // A path relative to the job file's folder becomes absolute.
  Status Path(const YAML::Node& node, const std::string& key, std::string* out) const {
    std::string text;
    GS_RETURN_IF_ERROR(String(node, key, &text));
    if (text.empty()) return Error(file_, node, "'" + key + "' is empty; expected a path");
    fs::path path(text);
    if (path.is_relative()) path = fs::absolute(fs::path(file_)).parent_path() / path;
    *out = path.lexically_normal().string();
    return Status::Ok();
  }

 private:
  std::string file_;
};

Status ParseSimulate(const Reader& r, const YAML::Node& node, RunSpec* run) {
  GS_RETURN_IF_ERROR(r.ExpectMap(node, "simulate",
                                 {"poses", "features", "runs", "gps_every", "seed", "block_size",
                                  "street_width", "speed", "dt", "sensor_range", "range_sigma",
                                  "bearing_sigma", "gps_sigma", "gps_denied_region",
                                  "feature_id_base", "scans", "scan_beams", "scan_max_range",
                                  "scan_range_sigma", "initial_position_sigma",
                                  "initial_heading_sigma"}));
  CampusSimulatorOptions& sim = run->simulate;
  for (const auto& entry : node) {
    const std::string key = entry.first.Scalar();
    const YAML::Node& v = entry.second;
    if (key == "poses") GS_RETURN_IF_ERROR(r.Int(v, key, 2, 100'000'000, &sim.poses));
    else if (key == "features") GS_RETURN_IF_ERROR(r.Int(v, key, 0, 100'000'000, &sim.features));
    else if (key == "runs") GS_RETURN_IF_ERROR(r.Int32(v, key, 1, 1000, &sim.runs));
    else if (key == "gps_every") GS_RETURN_IF_ERROR(r.Int32(v, key, 0, 1'000'000, &sim.gps_every));
    else if (key == "seed") {
      int64_t seed = 0;
      GS_RETURN_IF_ERROR(r.Int(v, key, 0, 4294967295LL, &seed));
      sim.seed = static_cast<uint32_t>(seed);
    } else if (key == "block_size") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.block_size));
    else if (key == "street_width") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.street_width));
    else if (key == "speed") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.speed));
    else if (key == "dt") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.dt));
    else if (key == "sensor_range") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.sensor_range));
    else if (key == "range_sigma") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.range_sigma));
    else if (key == "bearing_sigma") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.bearing_sigma));
    else if (key == "gps_sigma") GS_RETURN_IF_ERROR(r.Double(v, key, &sim.gps_sigma));
    else if (key == "feature_id_base")
      GS_RETURN_IF_ERROR(r.Int(v, key, 0, int64_t{1} << 50, &sim.feature_id_base));
    else if (key == "initial_position_sigma")
      GS_RETURN_IF_ERROR(r.Double(v, key, &sim.initial_position_sigma));
    else if (key == "initial_heading_sigma")
      GS_RETURN_IF_ERROR(r.Double(v, key, &sim.initial_heading_sigma));
    else if (key == "scans") GS_RETURN_IF_ERROR(r.Bool(v, key, &run->simulate_scans.enabled));
    else if (key == "scan_beams")
      GS_RETURN_IF_ERROR(r.Int32(v, key, 1, 100000, &run->simulate_scans.beams));
    else if (key == "scan_max_range") {
      GS_RETURN_IF_ERROR(r.Double(v, key, &run->simulate_scans.max_range));
      if (run->simulate_scans.max_range <= 0)
        return Error(r.file(), v, "'scan_max_range' must be > 0");
    } else if (key == "scan_range_sigma") {
      GS_RETURN_IF_ERROR(r.Double(v, key, &run->simulate_scans.range_sigma));
      if (run->simulate_scans.range_sigma < 0)
        return Error(r.file(), v, "'scan_range_sigma' must be >= 0");
    }
    else if (key == "gps_denied_region") {
      if (!v.IsSequence() || v.size() != 4)
        return Error(r.file(), v, "'gps_denied_region' must be [x0, y0, x1, y1]; expected 4 numbers");
      std::array<double, 4> box{};
      for (size_t i = 0; i < 4; ++i) GS_RETURN_IF_ERROR(r.Double(v[i], key, &box[i]));
      if (box[0] >= box[2] || box[1] >= box[3])
        return Error(r.file(), v, "'gps_denied_region' is empty; expected x0 < x1 and y0 < y1");
      run->gps_denied_region = box;
    }
  }
  if (Status status = sim.Validate(); !status.ok())
    return Error(r.file(), node, "simulate: " + status.message());
  return Status::Ok();
}

Status ParseGps(const Reader& r, const YAML::Node& node, RunSpec* run) {
  GpsSource gps;
  gps.line = node.Mark().line + 1;
  if (node.IsScalar()) {
    GS_RETURN_IF_ERROR(r.Path(node, "gps", &gps.path));
  } else {
    GS_RETURN_IF_ERROR(r.ExpectMap(node, "gps", {"path", "frame", "sigma", "max_time_difference"}));
    if (!node["path"]) return Error(r.file(), node, "gps has no 'path'; expected a CSV file");
    GS_RETURN_IF_ERROR(r.Path(node["path"], "path", &gps.path));
    if (node["frame"]) {
      GS_RETURN_IF_ERROR(r.String(node["frame"], "frame", &gps.frame));
      if (gps.frame != "wgs84" && gps.frame != "enu")
        return Error(r.file(), node["frame"],
                     "gps frame is '" + gps.frame + "'; expected wgs84 or enu");
    }
    if (node["sigma"]) {
      GS_RETURN_IF_ERROR(r.Double(node["sigma"], "sigma", &gps.sigma));
      if (gps.sigma <= 0) return Error(r.file(), node["sigma"], "gps sigma must be > 0");
    }
    if (node["max_time_difference"]) {
      GS_RETURN_IF_ERROR(
          r.Double(node["max_time_difference"], "max_time_difference", &gps.max_time_difference));
      if (gps.max_time_difference <= 0)
        return Error(r.file(), node["max_time_difference"], "max_time_difference must be > 0");
    }
  }
  run->gps = gps;
  return Status::Ok();
}

// ground_truth: FILE, or {path: FILE, format: auto|tum|kitti, times: FILE}.
Status ParseGroundTruth(const Reader& r, const YAML::Node& node, RunSpec* run) {
  if (node.IsScalar()) return r.Path(node, "ground_truth", &run->ground_truth);
  GS_RETURN_IF_ERROR(r.ExpectMap(node, "ground_truth", {"path", "format", "times"}));
  if (!node["path"])
    return Error(r.file(), node, "ground_truth has no 'path'; expected a TUM or KITTI file");
  GS_RETURN_IF_ERROR(r.Path(node["path"], "path", &run->ground_truth));
  if (node["format"]) {
    GS_RETURN_IF_ERROR(r.String(node["format"], "format", &run->ground_truth_format));
    if (run->ground_truth_format != "auto" && run->ground_truth_format != "tum" &&
        run->ground_truth_format != "kitti")
      return Error(r.file(), node["format"],
                   "ground_truth format '" + run->ground_truth_format +
                       "'; expected auto, tum or kitti");
  }
  if (node["times"]) {
    if (run->ground_truth_format == "tum")
      return Error(r.file(), node["times"], "'times' goes with KITTI poses; TUM carries its times");
    GS_RETURN_IF_ERROR(r.Path(node["times"], "times", &run->ground_truth_times));
  }
  return Status::Ok();
}

Status ParseRun(const Reader& r, const YAML::Node& node, RunSpec* run) {
  GS_RETURN_IF_ERROR(r.ExpectMap(node, "a run",
                                 {"name", "format", "path", "robot", "simulate", "gps",
                                  "ground_truth", "scans", "range_sigma", "bearing_sigma", "ids"}));
  run->line = node.Mark().line + 1;
  if (!node["name"]) return Error(r.file(), node, "run has no 'name'; expected name: <text>");
  GS_RETURN_IF_ERROR(r.String(node["name"], "name", &run->name));
  if (run->name.size() > kMaxRunNameBytes)
    return Error(r.file(), node["name"],
                 "run name '" + run->name.substr(0, 32) + "...' is " +
                     std::to_string(run->name.size()) + " bytes long; expected at most " +
                     std::to_string(kMaxRunNameBytes) +
                     " (it names files such as trajectories/<name>.tum)");
  const bool safe = !run->name.empty() &&
                    std::all_of(run->name.begin(), run->name.end(), [](char c) {
                      return std::isalnum(static_cast<unsigned char>(c)) || c == '_' ||
                             c == '-' || c == '.';
                    }) &&
                    run->name[0] != '.';
  if (!safe)
    return Error(r.file(), node["name"],
                 "run name '" + run->name + "' is not a plain file name; expected letters, "
                 "digits, '_', '-' or '.'");
  if (!node["format"]) return Error(r.file(), node, "run '" + run->name + "' has no 'format'");
  GS_RETURN_IF_ERROR(r.String(node["format"], "format", &run->format));
  static const std::set<std::string> kFormats = {"g2o", "isam", "mrclam", "native", "simulate"};
  if (!kFormats.contains(run->format))
    return Error(r.file(), node["format"],
                 "format '" + run->format + "'; expected g2o, isam, mrclam, native or simulate");
  if (run->format == "simulate") {
    if (node["path"])
      return Error(r.file(), node["path"], "a simulate run reads no 'path'; remove it");
    if (node["simulate"]) GS_RETURN_IF_ERROR(ParseSimulate(r, node["simulate"], run));
  } else {
    if (!node["path"]) return Error(r.file(), node, "run '" + run->name + "' has no 'path'");
    GS_RETURN_IF_ERROR(r.Path(node["path"], "path", &run->path));
    if (node["simulate"])
      return Error(r.file(), node["simulate"], "'simulate' options need format: simulate");
  }
  if (node["robot"]) {
    if (run->format != "mrclam")
      return Error(r.file(), node["robot"], "'robot' is for format: mrclam only");
    GS_RETURN_IF_ERROR(r.Int32(node["robot"], "robot", 1, 5, &run->robot));
  }
  for (const char* key : {"range_sigma", "bearing_sigma"}) {
    if (!node[key]) continue;
    if (run->format != "mrclam")
      return Error(r.file(), node[key],
                   std::string("'") + key + "' is for format: mrclam only (the others carry "
                   "their noise)");
    double sigma = 0;
    GS_RETURN_IF_ERROR(r.Double(node[key], key, &sigma));
    if (sigma <= 0) return Error(r.file(), node[key], std::string(key) + " must be > 0");
    (std::string(key) == "range_sigma" ? run->range_sigma : run->bearing_sigma) = sigma;
  }
  if (node["gps"]) GS_RETURN_IF_ERROR(ParseGps(r, node["gps"], run));
  if (node["ids"]) GS_RETURN_IF_ERROR(r.Bool(node["ids"], "ids", &run->ids));
  if (node["ground_truth"]) GS_RETURN_IF_ERROR(ParseGroundTruth(r, node["ground_truth"], run));
  if (node["scans"]) GS_RETURN_IF_ERROR(r.Path(node["scans"], "scans", &run->scans));
  return Status::Ok();
}

Status ParseMap(const Reader& r, const YAML::Node& node, MapSpec* map) {
  GS_RETURN_IF_ERROR(
      r.ExpectMap(node, "map", {"resolution", "max_range", "pcd_voxel", "sensor_height"}));
  struct Field {
    const char* key;
    double* value;
    bool zero_allowed;
  };
  for (const Field& f : {Field{"resolution", &map->resolution, false},
                         Field{"max_range", &map->max_range, false},
                         Field{"pcd_voxel", &map->pcd_voxel, true},
                         Field{"sensor_height", &map->sensor_height, true}}) {
    if (!node[f.key]) continue;
    GS_RETURN_IF_ERROR(r.Double(node[f.key], f.key, f.value));
    if (*f.value < 0 || (*f.value == 0 && !f.zero_allowed))
      return Error(r.file(), node[f.key],
                   std::string("map ") + f.key + (f.zero_allowed ? " must be >= 0" : " must be > 0"));
  }
  if (map->resolution < 0.01)
    return Error(r.file(), node, "map resolution is " + std::to_string(map->resolution) +
                                     " m; expected >= 0.01 m");
  return Status::Ok();
}

Status ParseSolver(const Reader& r, const YAML::Node& node, SolverSpec* solver) {
  GS_RETURN_IF_ERROR(r.ExpectMap(node, "solver",
                                 {"max_iterations", "function_tolerance", "model_tolerance",
                                  "robust_kernel",
                                  "initialization", "linear_solver", "repair_information"}));
  if (node["max_iterations"])
    GS_RETURN_IF_ERROR(
        r.Int32(node["max_iterations"], "max_iterations", 0, 100000, &solver->max_iterations));
  if (node["function_tolerance"])
    GS_RETURN_IF_ERROR(
        r.Double(node["function_tolerance"], "function_tolerance", &solver->function_tolerance));
  if (node["model_tolerance"])
    GS_RETURN_IF_ERROR(
        r.Double(node["model_tolerance"], "model_tolerance", &solver->model_tolerance));
  if (node["robust_kernel"])
    GS_RETURN_IF_ERROR(r.String(node["robust_kernel"], "robust_kernel", &solver->robust_kernel));
  if (node["linear_solver"])
    GS_RETURN_IF_ERROR(r.String(node["linear_solver"], "linear_solver", &solver->linear_solver));
  if (node["repair_information"])
    GS_RETURN_IF_ERROR(
        r.Bool(node["repair_information"], "repair_information", &solver->repair_information));
  if (node["initialization"]) {
    GS_RETURN_IF_ERROR(
        r.String(node["initialization"], "initialization", &solver->initialization));
    if (solver->initialization != "auto" && solver->initialization != "incremental" &&
        solver->initialization != "progressive" && solver->initialization != "odometry")
      return Error(r.file(), node["initialization"],
                   "initialization '" + solver->initialization +
                       "'; expected auto, incremental, progressive or odometry");
  }
  return Status::Ok();
}

}  // namespace

const char* StageName(Stage stage) {
  switch (stage) {
    case Stage::kIngest: return "ingest";
    case Stage::kInitialize: return "initialize";
    case Stage::kAssociate: return "associate";
    case Stage::kOptimize: return "optimize";
    case Stage::kMap: return "map";
    case Stage::kExport: return "export";
  }
  return "unknown";
}

bool JobSpec::HasStage(Stage stage) const {
  return std::find(stages.begin(), stages.end(), stage) != stages.end();
}

StatusOr<JobSpec> ParseJobSpec(const std::string& text, const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    std::ostringstream out;
    out << path << ":" << error.mark.line + 1 << ":" << error.mark.column + 1
        << ": not valid YAML: " << error.msg;
    return Status::InvalidArgument(out.str());
  }
  GS_RETURN_IF_ERROR(CheckDuplicateKeys(path, root));
  const Reader r(path);
  if (!root.IsMap())
    return Status::InvalidArgument(path + ":1:1: a job file is a mapping; expected output: and runs:");
  GS_RETURN_IF_ERROR(r.ExpectMap(root, "the job",
                                 {"output", "threads", "memory_limit", "stages", "solver", "runs",
                                  "compare_without_gps", "map", "robot_sightings"}));
  JobSpec job;
  job.path = path;
  // Without output: the folder must come from `graphslam run -o DIR` (RunJob checks).
  if (root["output"]) GS_RETURN_IF_ERROR(r.Path(root["output"], "output", &job.output));
  if (root["threads"]) GS_RETURN_IF_ERROR(r.Int32(root["threads"], "threads", 0, 1024, &job.threads));
  if (root["memory_limit"])
    GS_RETURN_IF_ERROR(r.Bytes(root["memory_limit"], "memory_limit", &job.memory_limit));
  if (root["solver"]) GS_RETURN_IF_ERROR(ParseSolver(r, root["solver"], &job.solver));
  if (root["map"]) GS_RETURN_IF_ERROR(ParseMap(r, root["map"], &job.map));
  if (root["compare_without_gps"])
    GS_RETURN_IF_ERROR(
        r.Bool(root["compare_without_gps"], "compare_without_gps", &job.compare_without_gps));
  if (root["robot_sightings"])
    GS_RETURN_IF_ERROR(r.Bool(root["robot_sightings"], "robot_sightings", &job.robot_sightings));
  if (root["stages"]) {
    const YAML::Node& stages = root["stages"];
    if (!stages.IsSequence())
      return Error(path, stages, "'stages' must be a list; expected e.g. [ingest, optimize, export]");
    std::set<Stage> chosen;
    for (const YAML::Node& s : stages) {
      std::string name;
      GS_RETURN_IF_ERROR(r.String(s, "stages", &name));
      bool found = false;
      for (Stage stage : kAllStages) {
        if (name == StageName(stage)) {
          chosen.insert(stage);
          found = true;
        }
      }
      if (!found)
        return Error(path, s, "unknown stage '" + name +
                                  "'; expected ingest, initialize, associate, optimize, map or export");
    }
    for (Stage stage : kAllStages)
      if (chosen.contains(stage)) job.stages.push_back(stage);
  } else {
    job.stages.assign(kAllStages.begin(), kAllStages.end());
  }
  if (!root["runs"]) return Error(path, root, "no 'runs'; expected a list of runs");
  const YAML::Node& runs = root["runs"];
  if (!runs.IsSequence() || runs.size() == 0)
    return Error(path, runs, "'runs' must be a non-empty list; expected - {name: ..., format: ...}");
  std::set<std::string> names;
  for (const YAML::Node& node : runs) {
    RunSpec run;
    GS_RETURN_IF_ERROR(ParseRun(r, node, &run));
    if (!names.insert(run.name).second)
      return Error(path, node["name"], "duplicate run name '" + run.name + "'");
    job.runs.push_back(std::move(run));
  }
  return job;
}

StatusOr<JobSpec> ReadJobSpec(const std::string& path) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(storage::Env::Default(), path,
                                                path + ": no such job file"));
  return ParseJobSpec(text, path);
}

}  // namespace graphslam::tools::job
