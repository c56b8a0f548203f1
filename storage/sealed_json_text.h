// A JSON object's text sealed with the CRC32C of its own bytes, for documents
// too large to build as a JSON tree (a solver checkpoint of 10^7 features is
// streamed straight into its file):
//
//   sealed = body + ",\"crc32c\":\"" + hex8(CRC32C(body)) + "\"}\n"
//
// where body is the object's text without its closing '}'. The CRC covers
// the exact bytes, so any edit (a digit, a deleted entry, even spacing) is
// detected; the seal is an ordinary key, so the document stays one JSON
// object. Unlike storage/checksummed_json.h it needs no parse to write.
//
// It detects damage and edits by hand, not an editor who recomputes it.
//
// THREAD SAFETY: pure functions. ALLOCATION: the returned text.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/status.h"

namespace graphslam::storage {

// The seal to append to `body` (the object's text up to, without, its '}')
// whose CRC32C is `crc` (storage/crc32c.h, unmasked): ",\"crc32c\":\"…\"}\n".
std::string JsonSealFor(uint32_t crc);

// `object_text` (one JSON object, as nlohmann dumps it) with its seal.
std::string SealJsonText(std::string_view object_text);

// Checks the seal of `text` read from `path`. Corruption naming the file if
// it has none, or if its bytes do not match it.
[[nodiscard]] Status CheckJsonTextSeal(const std::string& path, std::string_view text);

}  // namespace graphslam::storage
