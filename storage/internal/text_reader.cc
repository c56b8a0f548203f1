#include "storage/internal/text_reader.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "storage/internal/text_blocks.h"

namespace graphslam::storage::internal {

std::string BaseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

LineReader::LineReader(std::string name, std::string path)
    : name_(std::move(name)), path_(std::move(path)) {}

StatusOr<std::unique_ptr<LineReader>> LineReader::Open(const std::string& path) {
  std::unique_ptr<LineReader> reader(new LineReader(BaseName(path), path));
  GS_ASSIGN_OR_RETURN(reader->file_, InputFile::Open(path));
  return reader;
}

std::unique_ptr<LineReader> LineReader::ForTokenizedLines(const std::string& path) {
  return std::unique_ptr<LineReader>(new LineReader(BaseName(path), path));
}

void LineReader::Adopt(const TokenizedLine& line) {
  adopted_ = &line;
  line_number_ = line.line;
  fields_.clear();
  const int direct = std::min(line.num_fields, TokenizedLine::kMaxFields);
  fields_.assign(line.fields, line.fields + direct);
  fields_.insert(fields_.end(), line.overflow.begin(), line.overflow.end());
}

namespace {

constexpr size_t kBlockSize = size_t{1} << 20;

// std::isspace in the "C" locale, inline (the reader's hot loop).
inline bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

}  // namespace

Status LineReader::LineTooLong(int32_t line) const {
  return Status::Corruption(name_ + ":" + std::to_string(line) + ": line is longer than " +
                            std::to_string(kMaxLineBytes) +
                            " bytes; expected text records (a line of a supported format is < "
                            "1 KiB)");
}

bool LineReader::ReadLine() {
  carry_.clear();
  bool carrying = false;
  while (true) {
    if (block_begin_ < block_end_) {
      const char* begin = block_.data() + block_begin_;
      const size_t available = block_end_ - block_begin_;
      const auto* newline = static_cast<const char*>(std::memchr(begin, '\n', available));
      if (newline != nullptr) {
        const size_t length = static_cast<size_t>(newline - begin);
        block_begin_ += length + 1;
        if (!carrying) {
          line_ = std::string_view(begin, length);
        } else {
          carry_.append(begin, length);
          line_ = carry_;
        }
        if (line_.size() > kMaxLineBytes) {
          status_ = LineTooLong(line_number_ + 1);
          return false;
        }
        return true;
      }
      // The line goes on in the next block.
      carry_.append(begin, available);
      carrying = true;
      block_begin_ = block_end_;
      if (carry_.size() > kMaxLineBytes) {
        status_ = LineTooLong(line_number_ + 1);
        return false;
      }
    }
    if (end_of_file_) break;
    if (block_.empty()) block_.resize(kBlockSize);
    block_begin_ = 0;
    Status read;
    block_end_ = file_->Read(block_.data(), block_.size(), &read);
    if (block_end_ < block_.size()) {
      end_of_file_ = true;
      if (!read.ok()) {
        status_ = read.code() == Status::Code::kIOError
                      ? Status::IOError(path_ + ": read error after line " +
                                        std::to_string(line_number_))
                      : read;
        return false;
      }
    }
  }
  // The last line has no '\n' (std::getline semantics: returned if not empty).
  if (!carrying) return false;
  line_ = carry_;
  return true;
}

bool LineReader::Next() {
  adopted_ = nullptr;
  while (status_.ok() && ReadLine()) {
    ++line_number_;
    fields_.clear();
    const char* position = line_.data();
    const char* const end = position + line_.size();
    while (position < end) {
      while (position < end && IsSpace(*position)) ++position;
      if (position >= end) break;
      const char* token = position;
      while (position < end && !IsSpace(*position)) ++position;
      fields_.emplace_back(token, static_cast<size_t>(position - token));
    }
    if (fields_.empty() || fields_[0][0] == '#') continue;
    return true;
  }
  fields_.clear();
  return false;
}

std::string LineReader::Tag() const {
  return record_name_.empty() ? std::string(fields_[0]) : record_name_;
}

Status LineReader::Error(std::string_view what) const {
  return Status::Corruption(name_ + ":" + std::to_string(line_number_) + ": " + std::string(what));
}

Status LineReader::Unsupported(std::string_view what) const {
  return Status::NotSupported(name_ + ":" + std::to_string(line_number_) + ": " +
                              std::string(what));
}

Status LineReader::ExpectFieldCount(size_t expected) const {
  if (fields_.size() == expected) return Status::Ok();
  return Error(Tag() + " has " + std::to_string(fields_.size()) +
               " fields; expected " + std::to_string(expected));
}

Status LineReader::ExpectFieldCount(size_t first, size_t second) const {
  if (fields_.size() == first || fields_.size() == second) return Status::Ok();
  return Error(Tag() + " has " + std::to_string(fields_.size()) +
               " fields; expected " + std::to_string(first) + " or " + std::to_string(second));
}

Status CorruptionAt(const std::string& name, int32_t line, std::string_view what) {
  return Status::Corruption(name + ":" + std::to_string(line) + ": " + std::string(what));
}

bool ParseDouble(std::string_view token, double* value) {
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return error == std::errc() && end == token.data() + token.size();
}

bool ParseInt64(std::string_view token, int64_t* value) {
  if (!token.empty() && token[0] == '+') token.remove_prefix(1);
  if (token.empty()) return false;
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return error == std::errc() && end == token.data() + token.size();
}

Status LineReader::FieldError(size_t index, std::string_view what,
                              std::string_view expected) const {
  return Error(Tag() + " field " + std::to_string(index + 1) + " (" + std::string(what) +
               ") is '" + std::string(fields_[index]) + "'; expected " + std::string(expected));
}

double MagnitudeBound(Magnitude magnitude) {
  switch (magnitude) {
    case Magnitude::kValue: return 1e9;
    case Magnitude::kInformation: return 1e15;
    case Magnitude::kSqrtInformation: return 3.16e7;
    case Magnitude::kTime: return 1e12;
  }
  return 0.0;
}

std::string MagnitudeExpectation(Magnitude magnitude) {
  switch (magnitude) {
    case Magnitude::kValue:
      return "|x| <= 1e9 (the bound on coordinates, angles and measurements)";
    case Magnitude::kInformation:
      return "|x| <= 1e15 (the bound on information entries)";
    case Magnitude::kSqrtInformation:
      return "|x| <= 3.16e7 (the bound on square-root information entries)";
    case Magnitude::kTime:
      return "|x| <= 1e12 (the bound on time stamps in seconds)";
  }
  return "";
}

StatusOr<double> LineReader::Double(size_t index, std::string_view what,
                                    Magnitude magnitude) const {
  GS_CHECK(index < fields_.size());
  double value = 0.0;
  if (adopted_ != nullptr && index < static_cast<size_t>(TokenizedLine::kMaxConverted) &&
      ((adopted_->converted >> index) & 1u) != 0) {
    value = adopted_->values[index];  // converted by TokenizeBlock, same from_chars
  } else {
    if (!ParseDouble(fields_[index], &value)) return FieldError(index, what, "a number");
    if (!std::isfinite(value)) return FieldError(index, what, "a finite number");
  }
  if (!(std::abs(value) <= MagnitudeBound(magnitude)))
    return FieldError(index, what, MagnitudeExpectation(magnitude));
  return value;
}

StatusOr<int64_t> LineReader::Id(size_t index, std::string_view what) const {
  GS_CHECK(index < fields_.size());
  // [-]digits of <= 15 digits, converted exactly by TokenizeBlock: the
  // integer from_chars would give.
  if (adopted_ != nullptr && index < static_cast<size_t>(TokenizedLine::kMaxConverted) &&
      ((adopted_->integer >> index) & 1u) != 0)
    return static_cast<int64_t>(adopted_->values[index]);
  int64_t value = 0;
  if (!ParseInt64(fields_[index], &value)) return FieldError(index, what, "an integer id");
  return value;
}

bool LineReader::ValidDouble(size_t index, Magnitude magnitude, double* value) const {
  GS_CHECK(index < fields_.size());
  if (adopted_ != nullptr && index < static_cast<size_t>(TokenizedLine::kMaxConverted) &&
      ((adopted_->converted >> index) & 1u) != 0) {
    *value = adopted_->values[index];
  } else if (!ParseDouble(fields_[index], value) || !std::isfinite(*value)) {
    return false;
  }
  return std::abs(*value) <= MagnitudeBound(magnitude);
}

// Without a StatusOr per number (half the parse of a 3-D g2o file's edges);
// Double gives the message of the first invalid one.
Status LineReader::Doubles(size_t first, size_t count, std::string_view what, double* out,
                           Magnitude magnitude) const {
  for (size_t k = 0; k < count; ++k) {
    if (!ValidDouble(first + k, magnitude, &out[k]))
      return Double(first + k, what, magnitude).status();
  }
  return Status::Ok();
}

Eigen::Matrix3d SymmetricFromUpper3(const double upper[6]) {
  Eigen::Matrix3d m;
  m << upper[0], upper[1], upper[2],  //
      upper[1], upper[3], upper[4],   //
      upper[2], upper[4], upper[5];
  return m;
}

Eigen::Matrix2d SymmetricFromUpper2(const double upper[3]) {
  Eigen::Matrix2d m;
  m << upper[0], upper[1], upper[1], upper[2];
  return m;
}

bool IsPositiveDefinite(const Eigen::Matrix3d& matrix) {
  return matrix.allFinite() && Eigen::LLT<Eigen::Matrix3d>(matrix).info() == Eigen::Success;
}

bool IsPositiveDefinite(const Eigen::Matrix2d& matrix) {
  return matrix.allFinite() && Eigen::LLT<Eigen::Matrix2d>(matrix).info() == Eigen::Success;
}

std::string UpperTriangleString(const double* upper, int count) {
  std::string out = "[";
  for (int k = 0; k < count; ++k) {
    if (k > 0) out += ' ';
    out += FormatDouble(upper[k]);
  }
  return out + "]";
}

namespace {

// "%.17g" without printf: std::to_chars with chars_format::general and a
// precision is specified as printf's %.*g in the C locale ([charconv.to.chars]),
// so the bytes are the same (tested against snprintf), at a fraction of the
// cost (the store's problem.graphslam formats ~10 doubles per pose).
size_t FormatDouble17(double value, char* buffer, size_t size) {
  const auto [end, error] =
      std::to_chars(buffer, buffer + size, value, std::chars_format::general, 17);
  GS_CHECK(error == std::errc());
  return static_cast<size_t>(end - buffer);
}

}  // namespace

std::string FormatDouble(double value) {
  char buffer[32];
  return std::string(buffer, FormatDouble17(value, buffer, sizeof(buffer)));
}

}  // namespace graphslam::storage::internal

namespace graphslam::storage::internal {

void AppendField(std::string* line, std::string_view text) {
  if (!line->empty()) line->push_back(' ');
  line->append(text);
}

void AppendField(std::string* line, double value) {
  char buffer[32];
  AppendField(line, std::string_view(buffer, FormatDouble17(value, buffer, sizeof(buffer))));
}

void AppendField(std::string* line, int64_t value) {
  char buffer[24];
  const auto [end, error] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  GS_CHECK(error == std::errc());
  AppendField(line, std::string_view(buffer, static_cast<size_t>(end - buffer)));
}

void AppendUpperTriangle(std::string* line, const Eigen::Matrix3d& matrix) {
  for (int r = 0; r < 3; ++r) {
    for (int c = r; c < 3; ++c) AppendField(line, matrix(r, c));
  }
}

void AppendUpperTriangle(std::string* line, const Eigen::Matrix2d& matrix) {
  AppendField(line, matrix(0, 0));
  AppendField(line, matrix(0, 1));
  AppendField(line, matrix(1, 1));
}

}  // namespace graphslam::storage::internal
