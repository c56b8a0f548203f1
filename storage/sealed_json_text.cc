#include "storage/sealed_json_text.h"

#include <cctype>
#include <cstdio>

#include "storage/crc32c.h"

namespace graphslam::storage {
namespace {

constexpr std::string_view kSealKey = ",\"crc32c\":\"";

std::string Hex(uint32_t value) {
  char text[9];
  std::snprintf(text, sizeof(text), "%08x", value);
  return text;
}

}  // namespace

std::string JsonSealFor(uint32_t crc) {
  std::string seal(kSealKey);
  seal += Hex(crc);
  seal += "\"}\n";
  return seal;
}

std::string SealJsonText(std::string_view object_text) {
  while (!object_text.empty() && std::isspace(static_cast<unsigned char>(object_text.back())))
    object_text.remove_suffix(1);
  if (!object_text.empty() && object_text.back() == '}') object_text.remove_suffix(1);
  std::string sealed(object_text);
  sealed += JsonSealFor(crc32c::Value(object_text));
  return sealed;
}

Status CheckJsonTextSeal(const std::string& path, std::string_view text) {
  while (!text.empty() && std::isspace(static_cast<unsigned char>(text.back())))
    text.remove_suffix(1);
  const size_t at = text.rfind(kSealKey);
  const size_t hex = at + kSealKey.size();
  if (at == std::string_view::npos || text.size() != hex + 10 || text.substr(hex + 8) != "\"}")
    return Status::Corruption(path + ": no crc32c seal at the end; expected a file written by "
                                     "graphslam (an older build's, or one edited by hand, has "
                                     "none)");
  const std::string_view body = text.substr(0, at);
  const std::string expected(text.substr(hex, 8));
  const std::string actual = Hex(crc32c::Value(body));
  if (expected != actual)
    return Status::Corruption(path + ": crc32c of its " + std::to_string(body.size()) +
                              " bytes is " + actual + "; the file's seal says " + expected +
                              " (damaged or edited)");
  return Status::Ok();
}

}  // namespace graphslam::storage
