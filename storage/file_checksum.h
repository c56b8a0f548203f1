// Whole-file checksums: the CRC32C (storage/crc32c.h) and size of a file, and
// the identity of an input (a file, or a folder such as an MRCLAM dataset).
//
//   ChecksumFile(path)   = (size, CRC32C of the bytes), read in 1 MiB blocks
//   IdentifyInput(path)  file:   ChecksumFile(path)
//                        folder: bytes = sum of the regular files' sizes, crc =
//                                CRC32C of, for each regular file below it in
//                                sorted relative-path order, "<relative path>\0"
//                                followed by its bytes
//
// The chunk store manifest records both (docs/formats/chunk_store.md), and the
// ingest progress and `solve --workdir --resume` identify their input by them
// instead of an mtime, which a replaced file can keep. CRC32C is a check
// against damage and accidental replacement, not against an adversary who
// rewrites the checksum too (32 bits: a different file of the same size
// passes with probability 2^-32).
//
// THREAD SAFETY: pure functions of the files. ALLOCATION: one 1 MiB buffer.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace graphslam::storage {

struct FileChecksum {
  int64_t bytes = 0;
  uint32_t crc32c = 0;
  bool operator==(const FileChecksum&) const = default;
};

// NotFound / IOError naming the path.
StatusOr<FileChecksum> ChecksumFile(const std::string& path);
StatusOr<FileChecksum> IdentifyInput(const std::string& path);

// "0a1b2c3d" (8 lowercase hex digits) and back; false on anything else.
std::string FormatCrc32c(uint32_t crc);
bool ParseCrc32c(const std::string& text, uint32_t* crc);

}  // namespace graphslam::storage
