// The interface between graphslam_storage and libgraphslam_pcl, the module
// that holds every call into PCL (storage/pcl_module.cc).
//
// Why a module: PCL's io library loads VTK, Boost, OpenNI and ~60 other
// shared libraries, and the dynamic loader relocates all of them at every
// process start whether or not a .pcd is ever touched (docs/benchmarks.md,
// "Where the time goes"). The module is dlopen-ed on the first .pcd
// operation only (storage/internal/pcl_module_loader.h).
//
// Only standard-library types cross the boundary; the module is built by the
// same build with the same compiler, and the version below is checked at load.
//
// THREAD SAFETY: the functions are reentrant (PCL's readers and writers keep
// no shared state). ALLOCATION: the caller's vectors and strings.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace graphslam::map::internal {

// Bumped whenever PclModuleApi or the structs below change.
inline constexpr int kPclModuleApiVersion = 1;
// The symbol the module exports: `const PclModuleApi* graphslam_pcl_module()`.
inline constexpr char kPclModuleEntry[] = "graphslam_pcl_module";

// One field of a PCD file as PCL's reader decoded it.
struct PcdField {
  std::string name;
  uint32_t offset = 0;  // bytes from the start of a point
  bool float32 = false;
};

// A decoded cloud: width * height points of point_step bytes each.
struct PcdBlob {
  std::vector<PcdField> fields;
  uint32_t point_step = 0;
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> data;
};

struct PclModuleApi {
  int version;
  // Each returns an empty string on success, else what PCL reported.
  // The whole binary_compressed file (PCDWriter::writeBinaryCompressed) of
  // `points` points whose float32 fields `names` are interleaved in `values`
  // (points * names.size() floats, point after point).
  std::string (*encode_binary_compressed)(const std::vector<std::string>& names,
                                          const std::vector<float>& values, uint32_t points,
                                          std::string* out);
  // PCDWriter::generateHeaderBinaryCompressed for such a cloud, without the DATA line.
  std::string (*binary_compressed_header)(const std::vector<std::string>& names, uint32_t points,
                                          std::string* out);
  // pcl::lzfCompress: bytes written to `out` (at most `capacity`), 0 on failure.
  unsigned int (*lzf_compress)(const char* in, unsigned int n, char* out, unsigned int capacity);
  // pcl::io::loadPCDFile.
  std::string (*load)(const std::string& path, PcdBlob* out);
};

}  // namespace graphslam::map::internal
