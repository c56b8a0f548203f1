// Scans on disk, in chunks (spec: docs/formats/scan_chunk.md, version 1):
//
//   DIR/scans/NNNNNN.gss   chunk k: a header, one framed record per scan, a footer
//   DIR/scans/SCANS.json   manifest, written LAST (its presence commits the set)
//
// Like the observation chunks (docs/formats/observation_chunk.md) every record
// is framed [length u32][masked crc32c u32][payload] so damage, truncation and
// missing records are detected on read; little-endian throughout.
//
// ScanSource is what the map builder reads: chunks of scans, in order, one
// chunk in memory at a time. DiskScanStore, ThreeDtkScanSource (one 3DTK scan
// per chunk) and InMemoryScanSource implement it.
//
// THREAD SAFETY: Load() is const and safe to call concurrently.
// ALLOCATION: the writer holds one chunk; Load() one chunk.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/status.h"
#include "core/scan.h"

namespace graphslam::map {

inline constexpr const char* kScanStoreDirectory = "scans";
inline constexpr const char* kScanStoreManifest = "SCANS.json";
inline constexpr const char* kScanStoreFormat = "graphslam-scan-store";
inline constexpr int kScanStoreVersion = 1;

class ScanSource {
 public:
  virtual ~ScanSource() = default;
  virtual int64_t NumChunks() const = 0;
  [[nodiscard]] virtual Status Load(int64_t index, std::vector<Scan>* scans) const = 0;
};

class InMemoryScanSource : public ScanSource {
 public:
  InMemoryScanSource(std::vector<Scan> scans, size_t scans_per_chunk = 8)
      : scans_(std::move(scans)), per_chunk_(scans_per_chunk) {}
  int64_t NumChunks() const override {
    return static_cast<int64_t>((scans_.size() + per_chunk_ - 1) / per_chunk_);
  }
  Status Load(int64_t index, std::vector<Scan>* scans) const override;

 private:
  std::vector<Scan> scans_;
  size_t per_chunk_;
};

// Writes scans into DIR/scans/ as they come; Finish() writes the manifest.
// A chunk file is durable (atomic write) once it appears in entries(): a
// resumable producer (partition/ingest/ingest_scans.h) records entries() after each
// chunk and continues with Resume().
class ScanStoreWriter {
 public:
  struct Entry {
    std::string file;
    int64_t scans = 0, points = 0, bytes = 0;
  };

  // `dir` is created if missing; an old manifest is removed first.
  static StatusOr<std::unique_ptr<ScanStoreWriter>> Create(const std::string& dir,
                                                          int64_t target_chunk_bytes = 64 << 20);
  // As Create, continuing after the durable chunks `done` (files 0..k-1 as
  // recorded): the next chunk is number k.
  static StatusOr<std::unique_ptr<ScanStoreWriter>> Resume(const std::string& dir,
                                                          int64_t target_chunk_bytes,
                                                          std::vector<Entry> done);
  [[nodiscard]] Status Add(const Scan& scan);
  [[nodiscard]] Status Finish();
  // The chunks written so far (durable), in order.
  const std::vector<Entry>& entries() const { return entries_; }

 private:
  ScanStoreWriter() = default;
  [[nodiscard]] Status Flush();

  std::string dir_;  // DIR/scans
  int64_t target_bytes_ = 0;
  std::string pending_;  // framed records of the open chunk
  int64_t pending_scans_ = 0, pending_points_ = 0;
  std::vector<Entry> entries_;
};

class DiskScanStore : public ScanSource {
 public:
  // Opens DIR/scans/SCANS.json. NotFound / Corruption naming the file.
  static StatusOr<std::unique_ptr<DiskScanStore>> Open(const std::string& dir);
  static bool Exists(const std::string& dir);

  int64_t NumChunks() const override { return static_cast<int64_t>(files_.size()); }
  Status Load(int64_t index, std::vector<Scan>* scans) const override;
  int64_t total_scans() const { return total_scans_; }
  int64_t total_points() const { return total_points_; }

 private:
  DiskScanStore() = default;
  std::string dir_;
  std::vector<std::string> files_;
  std::vector<int64_t> scans_;
  int64_t total_scans_ = 0, total_points_ = 0;
};

// A 3DTK uos folder (storage/threedtk_reader.h): scan i of List3dtkScans is chunk
// i and belongs to pose i.
class ThreeDtkScanSource : public ScanSource {
 public:
  static StatusOr<std::unique_ptr<ThreeDtkScanSource>> Open(const std::string& dir);
  int64_t NumChunks() const override { return static_cast<int64_t>(numbers_.size()); }
  Status Load(int64_t index, std::vector<Scan>* scans) const override;

 private:
  std::string dir_;
  std::vector<int> numbers_;
};

}  // namespace graphslam::map
