#include "tools/job/job_state.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <ctime>
#include <cstdlib>
#include <vector>

#include "storage/atomic_file.h"
#include "storage/crc32c.h"

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

namespace {

namespace fs = std::filesystem;

constexpr const char* kStateFile = "state.json";

std::string Hex32(uint32_t value) {
  char text[9];
  std::snprintf(text, sizeof(text), "%08x", value);
  return text;
}

// The checksum of the state object without its own "state_crc32c".
std::string StateChecksum(nlohmann::json json) {
  json.erase("state_crc32c");
  return Hex32(storage::crc32c::Value(json.dump()));
}

StatusOr<FileDigest> DigestFile(const std::string& path) {
  StatusOr<std::unique_ptr<storage::ReadableFile>> file =
      storage::Env::Default()->NewReadableFile(path);
  if (!file.ok()) return file.status().WithContext("cannot open to check its checksum");
  FileDigest digest;
  std::vector<char> buffer(size_t{1} << 20);
  for (;;) {
    GS_ASSIGN_OR_RETURN(const size_t got, (*file)->Read(buffer.size(), buffer.data()));
    digest.crc32c = storage::crc32c::Extend(digest.crc32c, buffer.data(), got);
    digest.bytes += static_cast<int64_t>(got);
    if (got < buffer.size()) return digest;
  }
}

}  // namespace

StatusOr<std::map<std::string, FileDigest>> DigestJobFiles(const std::string& work) {
  std::map<std::string, FileDigest> files;
  GS_ASSIGN_OR_RETURN(const std::vector<std::string> relatives,
                      storage::Env::Default()->ListTree(work));
  for (const std::string& relative : relatives) {
    if (relative == kStateFile || relative.find(".tmp-") != std::string::npos) continue;
    GS_ASSIGN_OR_RETURN(files[relative], DigestFile((fs::path(work) / relative).string()));
  }
  return files;
}

Status VerifyJobFiles(const std::string& work, const JobState& state) {
  for (const auto& [relative, expected] : state.files) {
    const std::string path = (fs::path(work) / relative).string();
    if (storage::Env::Default()->KindOf(path) != storage::FileKind::kRegular)
      return Status::Corruption(path +
                                ": missing, but state.json lists it as the result of a completed "
                                "stage; run without --resume to start over");
    GS_ASSIGN_OR_RETURN(const FileDigest actual, DigestFile(path));
    if (!(actual == expected))
      return Status::Corruption(
          path + ": changed after the stage that wrote it completed (" +
          std::to_string(actual.bytes) + " bytes, crc32c " + Hex32(actual.crc32c) +
          "; state.json records " + std::to_string(expected.bytes) + " bytes, crc32c " +
          Hex32(expected.crc32c) + "); run without --resume to start over");
  }
  return Status::Ok();
}

StatusOr<JobState> ReadJobState(const std::string& path) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(storage::Env::Default(), path,
                                                path + ": cannot open the job state"));
  nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
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
  if (json["version"].get<int>() < kJobStateVersion)
    return Status::Corruption(path + ": job state version " +
                              std::to_string(json["version"].get<int>()) +
                              " carries no checksums; expected version " +
                              std::to_string(kJobStateVersion) +
                              " (run without --resume to start over)");
  if (!json.contains("state_crc32c") || !json["state_crc32c"].is_string())
    return Status::Corruption(path + ": field 'state_crc32c' missing; expected a string");
  if (json["state_crc32c"].get<std::string>() != StateChecksum(json))
    return Status::Corruption(path + ": checksum mismatch (state_crc32c " +
                              json["state_crc32c"].get<std::string>() + ", content " +
                              StateChecksum(json) +
                              "): the job state was edited or damaged; run without --resume "
                              "to start over");
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
  if (!json.contains("files") || !json["files"].is_object())
    return Status::Corruption(path + ": field 'files' missing; expected an object");
  for (const auto& [name, entry] : json["files"].items()) {
    if (!entry.is_object() || !entry.contains("bytes") || !entry["bytes"].is_number_integer() ||
        !entry.contains("crc32c") || !entry["crc32c"].is_string())
      return Status::Corruption(path + ": files entry '" + name +
                                "' is not {bytes: integer, crc32c: hex}");
    FileDigest digest;
    digest.bytes = entry["bytes"].get<int64_t>();
    digest.crc32c = static_cast<uint32_t>(
        std::strtoul(entry["crc32c"].get<std::string>().c_str(), nullptr, 16));
    state.files[name] = digest;
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
  json["files"] = nlohmann::json::object();
  for (const auto& [name, digest] : state.files)
    json["files"][name] = {{"bytes", digest.bytes}, {"crc32c", Hex32(digest.crc32c)}};
  json["state_crc32c"] = StateChecksum(json);
  return storage::WriteStringAtomically(storage::Env::Default(), path, json.dump(2) + "\n");
}

Status JobLog::Open(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  file_.reset();
  StatusOr<std::unique_ptr<storage::WritableFile>> file =
      storage::Env::Default()->NewAppendableFile(path);
  if (!file.ok()) return file.status().WithContext("cannot open the job log");
  file_ = std::move(file).value();
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
  if (file_->Append(line.dump() + "\n").ok()) (void)file_->Flush();
}

}  // namespace graphslam::tools::job
