// report.html: one self-contained page (no external files or scripts) built
// from report.json and the PNG plots (plots.h), which are embedded as
// base64 data URIs (RFC 4648 alphabet, '=' padding).
//
// THREAD SAFETY: reentrant. ALLOCATION: O(report + images).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace graphslam::tools::job {

std::string Base64(const std::string& bytes);

// `images`: (caption, PNG bytes) in display order.
std::string RenderReportHtml(const nlohmann::json& report,
                             const std::vector<std::pair<std::string, std::string>>& images);

}  // namespace graphslam::tools::job
