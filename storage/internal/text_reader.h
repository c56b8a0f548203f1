// Line-oriented text input shared by the importers (g2o, iSAM, MRCLAM, native
// log): a streaming line reader (1 MiB blocks split at '\n', never the whole
// file in memory)
// and a field parser whose errors follow the project format
//   "<file>:<line>: <what was wrong>; expected <what>"
// e.g. "intel.g2o:12: EDGE_SE2 has 9 fields; expected 12".
// <file> is the base name of the path, as in the example.
//
// Numbers are parsed with std::from_chars (locale-independent); a token must be
// consumed whole, and nan/inf are rejected (they would poison the solver).
// Magnitudes are bounded too (docs/cli.md, "Number ranges"): a value of 1e308
// is finite, but its square is not, so chi2 would overflow or the solve would
// "converge" on garbage. The bounds are far beyond any real data set (the
// largest information entry among the shipped data sets is 4e8, CSAIL.g2o):
//   kValue            |x| <= 1e9: coordinates [m], angles [rad], measurements,
//                     controls, noise parameters
//   kInformation      |x| <= 1e15: information matrix entries; with residuals
//                     below 2e9 a chi2 term stays below 1e34
//   kSqrtInformation  |x| <= 3.16e7 (sqrt 1e15): iSAM's square-root
//                     information R, so that R^T R stays within kInformation
//   kTime             |x| <= 1e12: time stamps [s] (year ~31 700)
//
// Lines are at most kMaxLineBytes (1 MiB) long: a longer line (e.g. a zstd
// "bomb" that decompresses to one 1 GB comment line) is Corruption
// "<file>:<line>: line is longer than 1048576 bytes; ...", found after at most
// that many bytes of it were buffered.
//
// Speed: the ingest reads every observation line through this class (twice
// for pass 1 of a native log), so the success path allocates nothing: lines are
// views into the block buffer (copied only when they straddle two blocks),
// whitespace is the C locale's set tested inline, and error messages are built
// only when a field is rejected.
//
// THREAD SAFETY: one reader per thread. ALLOCATION: one 1 MiB block buffer, a
// carry-over line buffer, and the token views.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"
#include "storage/compressed_file.h"

namespace graphslam::storage::internal {

// Base name of a path ("a/b/intel.g2o" -> "intel.g2o").
std::string BaseName(const std::string& path);

struct TokenizedLine;  // text_blocks.h

// A record line of any supported format is < 1 KiB; 1 MiB leaves room.
inline constexpr size_t kMaxLineBytes = size_t{1} << 20;

// Which bound a number read from text must respect (above).
enum class Magnitude { kValue, kInformation, kSqrtInformation, kTime };
double MagnitudeBound(Magnitude magnitude);
// "|x| <= 1e+09 (coordinates, angles and measurements)" and so on.
std::string MagnitudeExpectation(Magnitude magnitude);

class LineReader {
 public:
  // NotFound if the file does not exist, IOError if it cannot be opened.
  static StatusOr<std::unique_ptr<LineReader>> Open(const std::string& path);
  // A reader that reads nothing itself: lines tokenized elsewhere (in
  // parallel, text_blocks.h) are handed to it with Adopt, and its field
  // accessors and messages work as for a line it read (`path` names them).
  static std::unique_ptr<LineReader> ForTokenizedLines(const std::string& path);
  // Makes `line` the current line; Double uses its converted numbers. `line`
  // (and the text its fields view) must outlive its use.
  void Adopt(const TokenizedLine& line);

  // Reads the next line that is neither blank nor a comment (first non-blank
  // character '#') and splits it on whitespace into fields(). Returns false at
  // the end of the file or on a read error (then status() is not OK).
  bool Next();
  const std::vector<std::string_view>& fields() const { return fields_; }
  int32_t line_number() const { return line_number_; }
  const std::string& name() const { return name_; }  // base name, for messages
  const Status& status() const { return status_; }

  // For tag-less files (MRCLAM): messages say `record_name` where they would
  // name the tag (fields()[0]), e.g. "odometry record field 3 ...".
  void set_record_name(std::string record_name) { record_name_ = std::move(record_name); }

  // "<name>:<line>: <what>" as a Corruption.
  Status Error(std::string_view what) const;
  // The same with NotSupported.
  Status Unsupported(std::string_view what) const;

  // Checks fields().size() == expected: "<tag> has N fields; expected M".
  Status ExpectFieldCount(size_t expected) const;
  // Accepts either of two counts: "...; expected A or B".
  Status ExpectFieldCount(size_t first, size_t second) const;

  // Field `index` as a finite double within the bound of `magnitude`:
  // "<tag> field 3 (x) is 'abc'; expected a number", "... is 'nan'; expected a
  // finite number" or "... is '1e308'; expected |x| <= 1e+09 (...)".
  StatusOr<double> Double(size_t index, std::string_view what,
                          Magnitude magnitude = Magnitude::kValue) const;
  // Field `index` as an integer id: "...; expected an integer id".
  StatusOr<int64_t> Id(size_t index, std::string_view what) const;
  // `count` doubles starting at `first`.
  Status Doubles(size_t first, size_t count, std::string_view what, double* out,
                 Magnitude magnitude = Magnitude::kValue) const;

 private:
  LineReader(std::string name, std::string path);

  // The next line (without '\n') into line_; false at the end or on error.
  bool ReadLine();
  Status FieldError(size_t index, std::string_view what, std::string_view expected) const;
  Status LineTooLong(int32_t line) const;
  // Double's value without a Status: false where Double gives an error.
  bool ValidDouble(size_t index, Magnitude magnitude, double* value) const;

  std::string name_;
  std::string path_;
  std::unique_ptr<InputFile> file_;  // plain or zstd (storage/compressed_file.h)
  std::vector<char> block_;    // the current block of the file
  size_t block_begin_ = 0;     // first unread byte of block_
  size_t block_end_ = 0;       // bytes of block_ filled
  bool end_of_file_ = false;
  std::string carry_;          // a line that straddles two blocks
  std::string_view line_;
  const TokenizedLine* adopted_ = nullptr;
  std::vector<std::string_view> fields_;
  int32_t line_number_ = 0;
  Status status_;
  std::string record_name_;

  std::string Tag() const;
};

// "<name>:<line>: <what>" as a Corruption, for errors found after the line
// was read (e.g. an edge to a vertex that is never defined).
Status CorruptionAt(const std::string& name, int32_t line, std::string_view what);

// Parses a whole token as a finite double / integer (no reader context).
bool ParseDouble(std::string_view token, double* value);
bool ParseInt64(std::string_view token, int64_t* value);

// Builds the symmetric matrix from its upper triangle in row-first order
// (g2o: xx xy xt yy yt tt).
Eigen::Matrix3d SymmetricFromUpper3(const double upper[6]);
Eigen::Matrix2d SymmetricFromUpper2(const double upper[3]);
// True if the (symmetric) matrix is positive definite (Cholesky succeeds).
bool IsPositiveDefinite(const Eigen::Matrix3d& matrix);
bool IsPositiveDefinite(const Eigen::Matrix2d& matrix);
// "[a b c ...]" of the upper triangle, %.17g, for messages.
std::string UpperTriangleString(const double* upper, int count);

// "%.17g": a form that reads back to the identical double.
std::string FormatDouble(double value);

// Append one field to a record being written, preceded by a space unless the
// line is empty: numbers as "%.17g", ids in decimal.
void AppendField(std::string* line, std::string_view text);
void AppendField(std::string* line, double value);
void AppendField(std::string* line, int64_t value);
// The upper triangle of a symmetric matrix, row first.
void AppendUpperTriangle(std::string* line, const Eigen::Matrix3d& matrix);
void AppendUpperTriangle(std::string* line, const Eigen::Matrix2d& matrix);

}  // namespace graphslam::storage::internal
