// A JSON object that carries the CRC32C of its own contents, so that an edit
// of any value (a digit changed, an entry removed) is detected on read:
//
//   Seal(o)    o["checksum"] = hex CRC32C (storage/file_checksum.h) of
//              o.dump() without "checksum" (nlohmann's compact dump: keys
//              sorted, no spaces -- a canonical form of the parsed value, so
//              re-indenting the file does not matter, changing it does)
//   Unseal(o)  removes "checksum" and checks it: Corruption naming `where`
//              if it is missing, malformed, or does not match
//
// Used by the chunk store's MANIFEST.json and the ingest's progress record.
// It detects damage and edits by hand, not an editor who recomputes it.
//
// THREAD SAFETY: pure functions. ALLOCATION: one dump of the object.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/status.h"

namespace graphslam::storage {

inline constexpr const char* kJsonChecksumKey = "checksum";

// `object` must be a JSON object without a "checksum" key.
void SealJson(nlohmann::json* object);
[[nodiscard]] Status UnsealJson(nlohmann::json* object, const std::string& where);

}  // namespace graphslam::storage
