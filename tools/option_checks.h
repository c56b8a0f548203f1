// Range checks of numeric command-line options, as CLI11 validators shared by
// every subcommand: a value outside its range (nan, inf, a negative count,
// a zero trust region, ...) is rejected while the command line is parsed, as
// CLI::ValidationError "--function-tolerance: 'nan' is not a finite number;
// expected a number in [0, 1)", which main() turns into exit 1 (usage,
// tools/exit_codes.h) before anything is read or written.
//
//   Real(lower, upper, bounds)   a finite double within [lower, upper], each
//                                end closed or open as `bounds` says
//   Integer(lower, upper)        a whole number in [lower, upper]
//
// A CLI11 validator sees the text before conversion; Real parses it with
// std::from_chars (locale-independent, the whole token), so "nan", "inf",
// "1e999" and "0x10" are errors, not values.
//
// THREAD SAFETY: the validators hold only their bounds. ALLOCATION: the
// message of a failure.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <limits>
#include <string>

namespace graphslam::tools {

enum class Bounds { kClosed, kOpenLower, kOpenUpper, kOpen };

inline constexpr double kNoUpperBound = std::numeric_limits<double>::max();

// A finite double in the interval; `bounds` says which ends are excluded.
CLI::Validator Real(double lower, double upper, Bounds bounds = Bounds::kClosed);
// Shorthands: (0, max] and [0, max] (finite).
CLI::Validator PositiveReal();
CLI::Validator NonNegativeReal();
// A whole number in [lower, upper] (decimal, optional sign).
CLI::Validator Integer(int64_t lower, int64_t upper = std::numeric_limits<int64_t>::max());

// "[0, 1)", "(0, 1e16]", "[1, inf)": the interval as the messages print it.
std::string IntervalText(double lower, double upper, Bounds bounds);

}  // namespace graphslam::tools
