// ParseMemorySize: "2G", "512M", "64k", "1000" (bytes) -> bytes, for the
// --memory-limit options. Suffixes K, M, G, T (powers of 1024, either case,
// an optional trailing "B" or "iB"). InvalidArgument naming the text otherwise.
//
// THREAD SAFETY: pure. ALLOCATION: none beyond the message.
#pragma once

#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/status.h"

namespace graphslam::tools {

inline StatusOr<int64_t> ParseMemorySize(const std::string& text) {
  auto bad = [&text]() {
    return Status::InvalidArgument("memory size '" + text +
                                   "'; expected a number with an optional K, M, G or T suffix");
  };
  if (text.empty()) return bad();
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || !(value > 0)) return bad();
  std::string suffix(end);
  for (char& c : suffix) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (suffix.size() >= 2 && suffix.substr(suffix.size() - 2) == "IB") suffix.resize(suffix.size() - 2);
  else if (!suffix.empty() && suffix.back() == 'B') suffix.pop_back();
  double scale = 1;
  if (suffix == "K") scale = 1024.0;
  else if (suffix == "M") scale = 1024.0 * 1024;
  else if (suffix == "G") scale = 1024.0 * 1024 * 1024;
  else if (suffix == "T") scale = 1024.0 * 1024 * 1024 * 1024;
  else if (!suffix.empty()) return bad();
  const double bytes = value * scale;
  if (bytes > 9.0e18) return bad();
  return static_cast<int64_t>(bytes);
}

}  // namespace graphslam::tools
