// The registered cloud as a .pcd file (PCL's format, v0.7, DATA
// binary_compressed), written through PCL's own PCDWriter.
//
// Fields: x y z (float32, metres, world frame), then `intensity` (float32,
// mean of the voxel's points) when any scan had intensities, then `run`
// (float32, the run id of the voxel's first point) when any scan had a run id.
// The cloud is voxel-downsampled: one point per occupied voxel of edge `voxel`
// (the centroid of its points), in ascending voxel order, so the file is a
// deterministic function of the input. Downsampling is ours rather than
// pcl::VoxelGrid because VoxelGrid's 32-bit voxel index overflows at campus
// scale (600 m x 800 m x 50 m at 0.1 m is 2.4e10 voxels).
//
// VoxelCloud holds every voxel in memory: it is the reference the tests
// compare with; `graphslam map` uses TiledVoxelCloud
// (storage/tiled_voxel_cloud.h: the same points within a memory budget,
// streamed through BinaryCompressedPcdHeader and AppendLzfSegment below).
//
// PCL is confined to the module libgraphslam_pcl, loaded on the first call
// here (storage/internal/pcl_module_api.h): it costs process start nothing
// when no .pcd is touched. Each function returns NotSupported when the module
// cannot load.
// THREAD SAFETY: a VoxelCloud is used by one thread at a time.
// ALLOCATION: one accumulator (~48 bytes) per occupied voxel.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/status.h"
#include "core/scan.h"

namespace graphslam::map {

class VoxelCloud {
 public:
  explicit VoxelCloud(double voxel) : voxel_(voxel) {}

  // Adds the scan's points (already in the world frame) with its intensities
  // and run id.
  void Add(const std::vector<Eigen::Vector3f>& world_points, const Scan& scan);

  size_t size() const { return voxels_.size(); }
  bool has_intensity() const { return has_intensity_; }
  bool has_run() const { return has_run_; }

  struct Point {
    Eigen::Vector3f xyz;
    float intensity;
    float run;
  };
  // The downsampled points in ascending voxel order.
  std::vector<Point> Points() const;

 private:
  struct Accumulator {
    double x = 0, y = 0, z = 0, intensity = 0;
    int64_t count = 0;
    int32_t run = -1;
  };
  double voxel_;
  bool has_intensity_ = false;
  bool has_run_ = false;
  std::unordered_map<uint64_t, Accumulator> voxels_;
};

// Writes `cloud` to `path` atomically as described above. IOError naming the path.
[[nodiscard]] Status WritePcd(const std::string& path, const VoxelCloud& cloud);

// Building blocks of a streamed binary_compressed file (storage/tiled_voxel_cloud.h):
// PCL's header (PCDWriter::generateHeaderBinaryCompressed) for `points`
// points of the float32 fields `names`, ending with "DATA binary_compressed\n";
StatusOr<std::string> BinaryCompressedPcdHeader(const std::vector<std::string>& names,
                                                uint32_t points);
// and `n` bytes compressed by PCL's lzfCompress, appended to *out as one
// self-contained LZF segment (segments concatenate into a valid stream).
[[nodiscard]] Status AppendLzfSegment(const char* data, size_t n, std::string* out);

// What a .pcd holds, read back through PCL's own reader (pcl::io::loadPCDFile).
struct PcdContents {
  std::vector<Eigen::Vector3f> points;
  std::vector<float> intensity;  // empty if no intensity field
  std::vector<float> run;        // empty if no run field
  std::string data_type;         // from the header's DATA line
};
StatusOr<PcdContents> ReadPcd(const std::string& path);

}  // namespace graphslam::map
