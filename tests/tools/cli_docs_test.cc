// docs/cli.md against the binary's own --help, so the page cannot go stale:
// every option `graphslam <subcommand> --help` lists has a row in an option
// table of docs/cli.md, and every option a table row names exists. In a
// section whose heading names a subcommand ("## `graphslam solve`"), a row's
// options must belong to that subcommand; tables of topic sections (out of
// core, 3-D, ...) name options of any subcommand.
//
// An option table row is a Markdown table line whose first cell starts with
// an option in backticks: | `-o, --output FILE` | ... |.
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "tests/testing/subprocess.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

const std::vector<std::string> kSubcommands = {"solve", "simulate", "evaluate", "ingest",
                                               "map",   "run",      "benchmark"};
const std::string kTopLevel = "(graphslam)";

// Option names in the help of CLI11: lines "  -o,--output TEXT  ..." under
// "Options:" (and "Positionals:", which hold no dashes and are skipped).
std::set<std::string> HelpOptions(const std::string& help) {
  std::set<std::string> names;
  std::istringstream lines(help);
  std::string line;
  const std::regex option_line(R"(^\s+(--?[A-Za-z0-9][A-Za-z0-9,-]*))");
  while (std::getline(lines, line)) {
    std::smatch match;
    if (!std::regex_search(line, match, option_line)) continue;
    std::stringstream parts(match[1].str());
    std::string name;
    while (std::getline(parts, name, ','))
      if (!name.empty()) names.insert(name);
  }
  return names;
}

// Options named in the first cell of a table row of `markdown`, each with the
// subcommand of the section it stands in (kTopLevel for the top-level table,
// "" for topic sections).
std::vector<std::pair<std::string, std::string>> DocumentedOptions(const std::string& markdown) {
  std::vector<std::pair<std::string, std::string>> found;
  std::istringstream lines(markdown);
  std::string line, section;
  bool in_code = false;
  const std::regex heading(R"(^##\s+`?graphslam(\s+([a-z0-9]+))?`?\s*(.*)$)");
  const std::regex option(R"((^|[\s`,(])(--?[A-Za-z0-9][A-Za-z0-9-]*))");
  while (std::getline(lines, line)) {
    if (line.rfind("```", 0) == 0) in_code = !in_code;
    if (in_code) continue;
    if (line.rfind("## ", 0) == 0) {
      std::smatch match;
      section = "";
      if (std::regex_match(line, match, heading)) {
        const std::string sub = match[2].str();
        section = sub.empty() ? kTopLevel : sub;
        // "## graphslam simulate --3d --scans": still the simulate section.
      }
      continue;
    }
    if (line.rfind("| `-", 0) != 0) continue;
    const std::string cell = line.substr(2, line.find('|', 2) - 2);
    for (std::sregex_iterator it(cell.begin(), cell.end(), option), end; it != end; ++it)
      found.emplace_back((*it)[2].str(), section);
  }
  return found;
}

class CliDocs : public ::testing::Test {
 protected:
  void SetUp() override {
    capture_ = (fs::temp_directory_path() / ("graphslam_cli_docs_" + std::to_string(getpid())))
                   .string();
    std::ifstream in(std::string(GRAPHSLAM_SOURCE_DIR) + "/docs/cli.md");
    ASSERT_TRUE(in) << "docs/cli.md";
    std::stringstream text;
    text << in.rdbuf();
    documented_ = DocumentedOptions(text.str());
    ASSERT_FALSE(documented_.empty());
    for (const std::string& sub : kSubcommands) help_[sub] = Help({sub, "--help"});
    help_[kTopLevel] = Help({"--help"});
  }
  void TearDown() override {
    fs::remove(capture_ + ".out");
    fs::remove(capture_ + ".err");
  }

  std::set<std::string> Help(const std::vector<std::string>& args) {
    const testing::GraphslamRun run = testing::RunGraphslamCaptured(args, capture_);
    EXPECT_EQ(run.exit_code, 0) << run.err;
    const std::set<std::string> names = HelpOptions(run.out);
    EXPECT_FALSE(names.empty()) << run.out;
    return names;
  }

  std::string capture_;
  std::vector<std::pair<std::string, std::string>> documented_;
  std::map<std::string, std::set<std::string>> help_;
};

TEST_F(CliDocs, EveryHelpOptionIsDocumented) {
  for (const auto& [sub, names] : help_) {
    for (const std::string& name : names) {
      if ((name == "-h" || name == "--help") && sub != kTopLevel) continue;  // one row for all
      bool found = false;
      for (const auto& [option, section] : documented_)
        found = found || (option == name && (section == sub || section.empty()));
      EXPECT_TRUE(found) << sub << " --help lists " << name
                         << " but no option table of docs/cli.md (in its section or a topic "
                            "section) has it";
    }
  }
}

TEST_F(CliDocs, EveryDocumentedOptionExists) {
  for (const auto& [option, section] : documented_) {
    if (section.empty()) {
      bool exists = false;
      for (const auto& [sub, names] : help_) exists = exists || names.count(option) > 0;
      EXPECT_TRUE(exists) << "docs/cli.md documents " << option
                          << ", which no subcommand's --help lists";
    } else {
      const bool help = option == "-h" || option == "--help";
      EXPECT_TRUE(help_.at(section).count(option) > 0 || help)
          << "docs/cli.md documents " << option << " under " << section
          << ", whose --help does not list it";
    }
  }
}

}  // namespace
}  // namespace graphslam::tools
