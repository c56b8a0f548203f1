// Fuzz-target helper: the readers take paths, so each input is written to a
// private scratch file (or folder) first. One per process and target, reused
// for every input (libFuzzer runs inputs one after another in one thread).
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace graphslam::fuzz {

inline std::string ScratchPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_fuzz_" + std::to_string(getpid()) + "_" + name))
      .string();
}

inline void WriteBytes(const std::string& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string_view AsView(const uint8_t* data, size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

}  // namespace graphslam::fuzz
