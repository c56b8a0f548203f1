// The run name table beside a map.pcd (storage/pcd_run_names.h): written,
// read back, and its malformed forms named.
#include "storage/pcd_run_names.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace graphslam::storage {
namespace {

TEST(PcdRunNames, RoundTripsBesideTheCloud) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("gs_pcd_names_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string pcd = (dir / "map_c1.pcd").string();
  EXPECT_EQ(PcdRunNamesPath(pcd), (dir / "map_c1.runs.json").string());
  EXPECT_EQ(PcdRunNamesPath("cloud"), "cloud.runs.json");
  EXPECT_TRUE(ReadPcdRunNames(pcd).status().IsNotFound());
  const std::vector<std::string> names = {"campus_1", "campus_2", "lab"};
  ASSERT_TRUE(WritePcdRunNames(pcd, names).ok());
  StatusOr<std::vector<std::string>> read = ReadPcdRunNames(pcd);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(*read, names);

  struct Case {
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {"[1, 2", "not a JSON object"},
      {R"({"field": "x", "runs": []})", "'field' is not \"run\""},
      {R"({"field": "run"})", "no 'runs' list"},
      {R"({"field": "run", "runs": ["a", 3]})", "runs[1] is not a string"},
  };
  for (const Case& c : cases) {
    std::ofstream(PcdRunNamesPath(pcd)) << c.text;
    const Status status = ReadPcdRunNames(pcd).status();
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find("map_c1.runs.json: " + c.expected), std::string::npos)
        << status.message();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::storage
