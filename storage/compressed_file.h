// Transparent zstd for text inputs and outputs (the native log of a large
// simulation is ~82 bytes per observation as text; zstd brings it to a
// fraction of that, which is what lets 5*10^8 observations fit a disk next to
// their store).
//
//   InputFile         sequential reader of a file that is either plain or a
//                     zstd stream (one or more frames, recognized by the
//                     zstd magic number 0xFD2FB528 at byte 0, whatever the
//                     name): Read gives the DECOMPRESSED bytes. Offsets
//                     (Open's `offset`, errors, resume points of the
//                     ingest) count decompressed bytes; seeking in a zstd
//                     stream decompresses and drops the bytes before it.
//   ZstdWriter        compresses a sequence of appends into one zstd frame
//                     with a content checksum (so a flipped byte is caught
//                     on reading), written through a WritableFile.
//
// Errors name the file and where: a corrupt stream (bad frame header, bad
// block, checksum mismatch) is Corruption "<path>: corrupt zstd data (<zstd's
// reason>) in the compressed bytes before offset C (decompressed offset D)";
// a file that ends inside a frame is Corruption "<path>: truncated zstd
// stream: the file ends inside a frame at compressed offset C (decompressed
// offset D)". A plain file's read error is IOError naming the offset.
//
// Decompressed-size sanity bound: a zstd stream may give at most 1024 bytes
// per compressed byte read, plus 64 MiB; beyond that Read stops with
// Corruption "<path>: D decompressed bytes from C compressed bytes; expected
// at most 1024 times ..." (text compresses 3-20x; a 30 KB file that inflates
// to 1 GB is a bomb). The line readers also cap a line at 1 MiB
// (storage/internal/text_reader.h), which bounds their memory on any input.
//
// THREAD SAFETY: one object per thread. ALLOCATION: the zstd contexts and
// their ~1 MiB of buffers (plus the compressor's window: 8 MiB at level 3).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// True if the file starts with the zstd frame magic number (false if it is
// shorter or cannot be read).
bool IsZstdFile(const std::string& path);

class InputFile {
 public:
  // NotFound / InvalidArgument (a directory) / IOError naming the path; the
  // errors of reading up to `offset` (decompressed) for a zstd stream.
  static StatusOr<std::unique_ptr<InputFile>> Open(const std::string& path, int64_t offset = 0);
  virtual ~InputFile() = default;
  // Reads up to `size` bytes into `data`; fewer only at the end of the data
  // or on an error (then *status is set, and the bytes before it are given).
  virtual size_t Read(char* data, size_t size, Status* status) = 0;
  virtual bool compressed() const = 0;
};

class ZstdWriter {
 public:
  // `file` must outlive the writer; `level`: zstd's compression level
  // (1..19; 3 is zstd's default). `workers` > 0 compresses on that many
  // extra threads (zstd's own) while the caller produces the next bytes.
  ZstdWriter(WritableFile* file, int level, int workers = 0);
  ~ZstdWriter();
  ZstdWriter(const ZstdWriter&) = delete;
  ZstdWriter& operator=(const ZstdWriter&) = delete;

  [[nodiscard]] Status Append(std::string_view data);
  // Ends the frame and writes what is buffered; no Append afterwards.
  [[nodiscard]] Status Finish();
  int64_t bytes_in() const { return bytes_in_; }
  int64_t bytes_out() const { return bytes_out_; }

 private:
  Status Compress(std::string_view data, bool end);

  WritableFile* file_;
  struct Context;
  std::unique_ptr<Context> context_;
  std::string out_;
  int64_t bytes_in_ = 0;
  int64_t bytes_out_ = 0;
  bool finished_ = false;
};

}  // namespace graphslam::storage
