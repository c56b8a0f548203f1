// libgraphslam_pcl: every call into PCL, loaded on the first .pcd operation
// (storage/internal/pcl_module_api.h says why and what crosses the boundary).
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/lzf.h>
#include <pcl/io/pcd_io.h>

#include <cstring>
#include <sstream>

#include "storage/internal/pcl_module_api.h"

namespace graphslam::map::internal {
namespace {

// An unorganized cloud of `points` points with one FLOAT32 field per name,
// packed in order (PCL's point_step / row_step conventions); data left empty.
pcl::PCLPointCloud2 Float32CloudLayout(const std::vector<std::string>& names, uint32_t points) {
  pcl::PCLPointCloud2 blob;
  uint32_t offset = 0;
  for (const std::string& name : names) {
    pcl::PCLPointField field;
    field.name = name;
    field.offset = offset;
    field.datatype = pcl::PCLPointField::FLOAT32;
    field.count = 1;
    blob.fields.push_back(field);
    offset += 4;
  }
  blob.point_step = offset;
  blob.width = points;
  blob.height = 1;
  blob.row_step = blob.point_step * blob.width;
  blob.is_dense = true;
  return blob;
}

std::string EncodeBinaryCompressed(const std::vector<std::string>& names,
                                   const std::vector<float>& values, uint32_t points,
                                   std::string* out) {
  pcl::PCLPointCloud2 blob = Float32CloudLayout(names, points);
  if (values.size() != static_cast<size_t>(points) * names.size())
    return "expected " + std::to_string(static_cast<size_t>(points) * names.size()) +
           " values, got " + std::to_string(values.size());
  blob.data.resize(static_cast<size_t>(blob.row_step));
  if (!values.empty()) std::memcpy(blob.data.data(), values.data(), blob.data.size());
  std::ostringstream stream;
  pcl::PCDWriter writer;
  if (writer.writeBinaryCompressed(stream, blob) != 0) return "PCL could not encode the cloud";
  *out = stream.str();
  return {};
}

std::string BinaryCompressedHeader(const std::vector<std::string>& names, uint32_t points,
                                   std::string* out) {
  const pcl::PCLPointCloud2 blob = Float32CloudLayout(names, points);
  pcl::PCDWriter writer;
  *out = writer.generateHeaderBinaryCompressed(blob, Eigen::Vector4f::Zero(),
                                               Eigen::Quaternionf::Identity());
  return {};
}

unsigned int LzfCompress(const char* in, unsigned int n, char* out, unsigned int capacity) {
  return pcl::lzfCompress(in, n, out, capacity);
}

std::string Load(const std::string& path, PcdBlob* out) {
  pcl::PCLPointCloud2 blob;
  if (pcl::io::loadPCDFile(path, blob) != 0) return "PCL's loadPCDFile failed";
  out->fields.clear();
  for (const pcl::PCLPointField& f : blob.fields)
    out->fields.push_back({f.name, f.offset, f.datatype == pcl::PCLPointField::FLOAT32});
  out->point_step = blob.point_step;
  out->width = blob.width;
  out->height = blob.height;
  out->data = std::move(blob.data);
  return {};
}

constexpr PclModuleApi kApi = {kPclModuleApiVersion, &EncodeBinaryCompressed,
                               &BinaryCompressedHeader, &LzfCompress, &Load};

}  // namespace
}  // namespace graphslam::map::internal

extern "C" __attribute__((visibility("default"))) const graphslam::map::internal::PclModuleApi*
graphslam_pcl_module() {
  return &graphslam::map::internal::kApi;
}
