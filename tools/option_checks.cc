#include "tools/option_checks.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <string_view>

namespace graphslam::tools {
namespace {

std::string NumberText(double value) {
  if (value == kNoUpperBound) return "inf";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%g", value);
  return buffer;
}

bool ParseWhole(std::string_view text, double* value) {
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *value);
  return error == std::errc() && end == text.data() + text.size();
}

bool ParseWhole(std::string_view text, int64_t* value) {
  if (!text.empty() && text[0] == '+') text.remove_prefix(1);
  if (text.empty()) return false;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), *value);
  return error == std::errc() && end == text.data() + text.size();
}

}  // namespace

std::string IntervalText(double lower, double upper, Bounds bounds) {
  const bool open_lower = bounds == Bounds::kOpenLower || bounds == Bounds::kOpen;
  const bool open_upper =
      bounds == Bounds::kOpenUpper || bounds == Bounds::kOpen || upper == kNoUpperBound;
  return std::string(open_lower ? "(" : "[") + NumberText(lower) + ", " + NumberText(upper) +
         (open_upper ? ")" : "]");
}

CLI::Validator Real(double lower, double upper, Bounds bounds) {
  const std::string interval = IntervalText(lower, upper, bounds);
  const bool open_lower = bounds == Bounds::kOpenLower || bounds == Bounds::kOpen;
  const bool open_upper = bounds == Bounds::kOpenUpper || bounds == Bounds::kOpen;
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double value = 0.0;
        const std::string expected = "; expected a number in " + interval;
        if (!ParseWhole(text, &value)) return "'" + text + "' is not a number" + expected;
        if (!std::isfinite(value)) return "'" + text + "' is not a finite number" + expected;
        const bool above_lower = open_lower ? value > lower : value >= lower;
        const bool below_upper = open_upper ? value < upper : value <= upper;
        if (!above_lower || !below_upper) return "'" + text + "' is out of range" + expected;
        return std::string();
      },
      "REAL in " + interval, "REAL");
}

CLI::Validator PositiveReal() { return Real(0.0, kNoUpperBound, Bounds::kOpenLower); }

CLI::Validator NonNegativeReal() { return Real(0.0, kNoUpperBound); }

CLI::Validator Integer(int64_t lower, int64_t upper) {
  const std::string interval =
      "[" + std::to_string(lower) + ", " +
      (upper == std::numeric_limits<int64_t>::max() ? std::string("inf)")
                                                    : std::to_string(upper) + "]");
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        int64_t value = 0;
        const std::string expected = "; expected a whole number in " + interval;
        if (!ParseWhole(text, &value)) return "'" + text + "' is not a whole number" + expected;
        if (value < lower || value > upper) return "'" + text + "' is out of range" + expected;
        return std::string();
      },
      "INT in " + interval, "INT");
}

}  // namespace graphslam::tools
