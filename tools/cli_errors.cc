#include "tools/cli_errors.h"

#include <CLI/CLI.hpp>
#include <algorithm>

namespace graphslam::tools {
namespace {

std::vector<std::string> SubcommandNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    names.push_back(sub->get_name());
  return names;
}

// "--name" and "-n" forms of every option of `app` (positionals excluded).
std::vector<std::string> OptionNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::Option* option : app.get_options()) {
    for (const std::string& l : option->get_lnames()) names.push_back("--" + l);
    for (const std::string& s : option->get_snames()) names.push_back("-" + s);
  }
  return names;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (i > 0) out += i + 1 == names.size() ? " or " : ", ";
    out += names[i];
  }
  return out;
}

// Index of the first argument that is not an option (the subcommand), or argc.
int FirstWord(int argc, const char* const* argv) {
  for (int i = 1; i < argc; ++i)
    if (argv[i][0] != '-') return i;
  return argc;
}

// CLI11 messages can span lines; a script reads the first line of stderr.
std::string OneLine(std::string text) {
  std::string out;
  bool space = false;
  for (char c : text) {
    if (c == '\n' || c == '\r' || c == '\t') {
      space = !out.empty();
      continue;
    }
    if (space && c != ' ') out.push_back(' ');
    space = false;
    out.push_back(c);
  }
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

}  // namespace

int EditDistance(std::string_view a, std::string_view b) {
  const size_t n = a.size(), m = b.size();
  std::vector<std::vector<int>> d(n + 1, std::vector<int>(m + 1, 0));
  for (size_t i = 0; i <= n; ++i) d[i][0] = static_cast<int>(i);
  for (size_t j = 0; j <= m; ++j) d[0][j] = static_cast<int>(j);
  for (size_t i = 1; i <= n; ++i) {
    for (size_t j = 1; j <= m; ++j) {
      const int cost = a[i - 1] == b[j - 1] ? 0 : 1;
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + cost});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
        d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  }
  return d[n][m];
}

std::string Suggest(std::string_view typed, const std::vector<std::string>& candidates) {
  const int limit = std::max(2, static_cast<int>(typed.size()) / 3);
  std::string best;
  int best_distance = limit + 1;
  for (const std::string& candidate : candidates) {
    const int distance = EditDistance(typed, candidate);
    if (distance < best_distance) {
      best_distance = distance;
      best = candidate;
    }
  }
  return best;
}

std::string UnknownSubcommandLine(const CLI::App& app, int argc, const char* const* argv) {
  const std::vector<std::string> names = SubcommandNames(app);
  const int word = FirstWord(argc, argv);
  if (word == argc) {
    for (int i = 1; i < argc; ++i) {
      const std::string_view arg = argv[i];
      if (arg == "-h" || arg == "--help" || arg == "--version") return "";
    }
    if (argc > 1) return "";  // an unknown global option: UsageErrorLine names it
    return "graphslam: a subcommand is required; expected one of " + JoinNames(names) +
           " (graphslam --help)";
  }
  const std::string typed = argv[word];
  if (std::find(names.begin(), names.end(), typed) != names.end()) return "";
  std::string line = "graphslam: unknown subcommand '" + typed + "'";
  if (const std::string near = Suggest(typed, names); !near.empty())
    line += "; did you mean '" + near + "'?";
  return line + " (expected one of " + JoinNames(names) + ")";
}

std::string UsageErrorLine(const CLI::App& app, int argc, const char* const* argv,
                           const CLI::ParseError& error) {
  const int word = FirstWord(argc, argv);
  const CLI::App* sub = nullptr;
  if (word < argc) {
    for (const CLI::App* candidate :
         app.get_subcommands([](const CLI::App*) { return true; }))
      if (candidate->get_name() == argv[word]) sub = candidate;
  }
  const std::string prefix = sub ? "graphslam " + sub->get_name() + ": " : "graphslam: ";
  const CLI::App& scope = sub ? *sub : app;
  // An unknown option: name the first one, with a suggestion.
  const std::vector<std::string> known = OptionNames(scope);
  for (int i = sub ? word + 1 : 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--") break;
    if (arg.size() < 2 || arg[0] != '-') continue;
    if (const size_t eq = arg.find('='); eq != std::string::npos) arg.resize(eq);
    // "-vv" and "-ofile": short flags and attached values are CLI11's to judge.
    if (arg[1] != '-' && arg.size() > 2) arg.resize(2);
    if (std::find(known.begin(), known.end(), arg) != known.end()) continue;
    if (arg == "-h" || arg == "--help") continue;
    if (!sub && arg == "--version") continue;
    // A negative number (-1, -.5) is a value, not an option.
    if ((arg[1] >= '0' && arg[1] <= '9') || arg[1] == '.') continue;
    std::string line = prefix + "unknown option '" + arg + "'";
    if (const std::string near = Suggest(arg, known); !near.empty())
      line += "; did you mean '" + near + "'?";
    return line + " (graphslam " + (sub ? sub->get_name() + " " : std::string()) + "--help)";
  }
  return prefix + OneLine(error.what());
}

}  // namespace graphslam::tools
