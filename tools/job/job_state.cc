#include "tools/job/job_state.h"

#include <chrono>
#include <ctime>
#include <fstream>
#include <sstream>

#include "storage/atomic_file.h"

namespace graphslam::tools::job {

bool JobState::IsCompleted(const std::string& stage) const { return Find(stage) != nullptr; }

const CompletedStage* JobState::Find(const std::string& stage) const {
  for (const CompletedStage& c : completed)
    if (c.stage == stage) return &c;
  return nullptr;
}

std::string Fingerprint(const std::string& bytes) {
  uint64_t hash = 14695981039346656037ULL;
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 1099511628211ULL;
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

StatusOr<JobState> ReadJobState(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": cannot open the job state");
  std::stringstream buffer;
  buffer << in.rdbuf();
  nlohmann::json json = nlohmann::json::parse(buffer.str(), nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object())
    return Status::Corruption(path + ": not a JSON object; expected a job state");
  if (json.value("format", "") != kJobStateFormat)
    return Status::Corruption(path + ": field 'format' is not '" + kJobStateFormat + "'");
  if (!json.contains("version") || !json["version"].is_number_integer())
    return Status::Corruption(path + ": field 'version' missing; expected an integer");
  if (json["version"].get<int>() > kJobStateVersion)
    return Status::NotSupported(path + ": job state version " +
                                std::to_string(json["version"].get<int>()) + "; expected <= " +
                                std::to_string(kJobStateVersion));
  JobState state;
  if (!json.contains("job_fingerprint") || !json["job_fingerprint"].is_string())
    return Status::Corruption(path + ": field 'job_fingerprint' missing; expected a string");
  state.job_fingerprint = json["job_fingerprint"].get<std::string>();
  if (!json.contains("completed") || !json["completed"].is_array())
    return Status::Corruption(path + ": field 'completed' missing; expected an array");
  for (const nlohmann::json& entry : json["completed"]) {
    if (!entry.is_object() || !entry.contains("stage") || !entry["stage"].is_string())
      return Status::Corruption(path + ": an entry of 'completed' has no 'stage' string");
    CompletedStage stage;
    stage.stage = entry["stage"].get<std::string>();
    stage.seconds = entry.value("seconds", 0.0);
    stage.peak_rss_bytes = entry.value("peak_rss_bytes", int64_t{0});
    state.completed.push_back(stage);
  }
  return state;
}

Status WriteJobState(const std::string& path, const JobState& state) {
  nlohmann::json json;
  json["format"] = kJobStateFormat;
  json["version"] = kJobStateVersion;
  json["job_fingerprint"] = state.job_fingerprint;
  json["completed"] = nlohmann::json::array();
  for (const CompletedStage& c : state.completed)
    json["completed"].push_back(
        {{"stage", c.stage}, {"seconds", c.seconds}, {"peak_rss_bytes", c.peak_rss_bytes}});
  return storage::WriteStringAtomically(storage::Env::Default(), path, json.dump(2) + "\n");
}

JobLog::~JobLog() {
  if (file_ != nullptr) std::fclose(file_);
}

Status JobLog::Open(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (file_ != nullptr) std::fclose(file_);
  file_ = std::fopen(path.c_str(), "a");
  if (file_ == nullptr) return Status::IOError("cannot open the job log " + path);
  return Status::Ok();
}

void JobLog::Write(nlohmann::json event) {
  const auto now = std::chrono::system_clock::now();
  const std::time_t seconds = std::chrono::system_clock::to_time_t(now);
  const int millis = static_cast<int>(
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char stamp[80];
  std::snprintf(stamp, sizeof(stamp), "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, millis);
  nlohmann::json line = {{"time", stamp}};
  line.update(event);
  std::lock_guard<std::mutex> lock(mutex_);
  if (file_ == nullptr) return;
  const std::string text = line.dump() + "\n";
  std::fwrite(text.data(), 1, text.size(), file_);
  std::fflush(file_);
}

}  // namespace graphslam::tools::job
