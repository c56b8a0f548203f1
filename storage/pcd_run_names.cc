#include "storage/pcd_run_names.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "storage/atomic_file.h"

namespace graphslam::storage {

std::string PcdRunNamesPath(const std::string& pcd_path) {
  const std::string suffix = ".pcd";
  if (pcd_path.size() > suffix.size() &&
      pcd_path.compare(pcd_path.size() - suffix.size(), suffix.size(), suffix) == 0)
    return pcd_path.substr(0, pcd_path.size() - suffix.size()) + ".runs.json";
  return pcd_path + ".runs.json";
}

Status WritePcdRunNames(const std::string& pcd_path, const std::vector<std::string>& run_names,
                        Env* env) {
  if (env == nullptr) env = Env::Default();
  const nlohmann::json table = {
      {"pcd", std::filesystem::path(pcd_path).filename().string()},
      {"field", "run"},
      {"runs", run_names}};
  return WriteStringAtomically(env, PcdRunNamesPath(pcd_path), table.dump(1) + "\n");
}

StatusOr<std::vector<std::string>> ReadPcdRunNames(const std::string& pcd_path) {
  const std::string path = PcdRunNamesPath(pcd_path);
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": no run name table");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const nlohmann::json table = nlohmann::json::parse(buffer.str(), nullptr, false);
  if (table.is_discarded() || !table.is_object())
    return Status::Corruption(path + ": not a JSON object; expected {\"field\": \"run\", "
                              "\"runs\": [names]}");
  if (table.value("field", std::string()) != "run")
    return Status::Corruption(path + ": 'field' is not \"run\"; expected the name of the "
                              "index field of the cloud");
  const auto runs = table.find("runs");
  if (runs == table.end() || !runs->is_array())
    return Status::Corruption(path + ": no 'runs' list; expected the run names by index");
  std::vector<std::string> names;
  for (const nlohmann::json& name : *runs) {
    if (!name.is_string())
      return Status::Corruption(path + ": runs[" + std::to_string(names.size()) +
                                "] is not a string; expected a run name");
    names.push_back(name.get<std::string>());
  }
  return names;
}

}  // namespace graphslam::storage
