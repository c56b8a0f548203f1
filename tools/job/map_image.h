// The top-down picture of a job's 3-D map for the report: the points of its
// .pcd files (storage/pcd_io.h, with the run id of every point) projected
// onto the ground plane and binned into square pixels, each pixel coloured by
// the run with the most points in it (SeriesColour(run), svg_figure.h) and
// shaded by its point count on a log scale,
//
//   colour = white + (run colour - white) * (0.3 + 0.7 log(1 + n) / log(1 + n_max)),
//
// so walls (many points stacked in one column) stand out from the ground.
// The pixel size is the map's extent / max_pixels (longer side), at least
// min_pixel (m).
//
// The PNG (RFC 2083: 8-bit RGB, no interlace, filter 0, zlib-deflated IDAT,
// CRC-32 per chunk) is written by EncodePng.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(points + pixels).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::tools::job {

struct MapRaster {
  std::string png;
  double x0 = 0, x1 = 0, y0 = 0, y1 = 0;  // m, the area the picture covers
  int64_t points = 0;
  std::vector<int> runs;  // run ids present, ascending
};

// Errors of reading a file name it (storage::ReadPcd). A map without points
// gives an empty `png`.
StatusOr<MapRaster> RenderMapRaster(const std::vector<std::string>& pcd_paths, int max_pixels,
                                    double min_pixel = 0.0);

// `rgb`: width * height * 3 bytes, rows top to bottom.
std::string EncodePng(int width, int height, const std::vector<uint8_t>& rgb);

}  // namespace graphslam::tools::job
