// Usage errors of the graphslam command line in one format:
//
//   graphslam <subcommand>: <message>      (one line, exit 1 = kExitUsage)
//   graphslam: <message>                   (no or an unknown subcommand)
//
// and "did you mean" suggestions for mistyped subcommands and options: the
// known name at the least optimal-string-alignment distance (Levenshtein plus
// adjacent transpositions, so "slove" -> "solve" costs 1) is offered when
// that distance is at most max(2, |typed| / 3); beyond that a suggestion is
// more often wrong than helpful.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(|argv| + names).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "tools/cli_fwd.h"

namespace graphslam::tools {

// Optimal string alignment distance between a and b.
int EditDistance(std::string_view a, std::string_view b);

// The candidate nearest to `typed` within the threshold above; "" if none.
std::string Suggest(std::string_view typed, const std::vector<std::string>& candidates);

// The one-line message for a CLI11 parse error of `app` (the top-level app)
// given the command line argv[1..argc). Finds the subcommand in argv, names an
// unknown subcommand or option with a suggestion, and folds CLI11's
// multi-line messages into one line. No trailing newline.
std::string UsageErrorLine(const CLI::App& app, int argc, const char* const* argv,
                           const CLI::ParseError& error);

// The one-line message when argv names no known subcommand ("" when it
// does, or when argv asks only for --help / --version): checked before
// parsing, because CLI11 would report a mistyped subcommand as "A subcommand
// is required".
std::string UnknownSubcommandLine(const CLI::App& app, int argc, const char* const* argv);

}  // namespace graphslam::tools
