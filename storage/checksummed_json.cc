#include "storage/checksummed_json.h"

#include "storage/crc32c.h"
#include "storage/file_checksum.h"

namespace graphslam::storage {

void SealJson(nlohmann::json* object) {
  GS_CHECK(object != nullptr && object->is_object() && !object->contains(kJsonChecksumKey));
  (*object)[kJsonChecksumKey] = FormatCrc32c(crc32c::Value(object->dump()));
}

Status UnsealJson(nlohmann::json* object, const std::string& where) {
  GS_CHECK(object != nullptr);
  if (!object->is_object()) return Status::Corruption(where + ": not a JSON object");
  auto it = object->find(kJsonChecksumKey);
  uint32_t stored = 0;
  if (it == object->end() || !it->is_string() || !ParseCrc32c(it->get<std::string>(), &stored))
    return Status::Corruption(where + ": missing or malformed \"checksum\" (8 hex digits)");
  object->erase(it);
  const uint32_t actual = crc32c::Value(object->dump());
  if (actual != stored)
    return Status::Corruption(where + ": checksum mismatch (recorded " + FormatCrc32c(stored) +
                              ", contents give " + FormatCrc32c(actual) +
                              "): the file was edited or damaged");
  return Status::Ok();
}

}  // namespace graphslam::storage
