// Status and StatusOr<T>: errors as values, after LevelDB's Status.
//
// Anything that can fail because of input, disk or numerics returns a Status
// (or a StatusOr<T> carrying either a value or the error). Messages name the
// file, the record or offset, the id, and the expected versus actual value:
//   Status::Corruption("victoria.g2o:12: EDGE_SE2 expects 11 fields, got 9")
// No exception crosses a module boundary.
//
// THREAD SAFETY: a Status is a value; distinct objects may be used from
// distinct threads. ALLOCATION: an OK status allocates nothing.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "core/check.h"

namespace graphslam {

class [[nodiscard]] Status {
 public:
  enum class Code {
    kOk = 0,
    kNotFound,
    kCorruption,
    kNotSupported,
    kInvalidArgument,
    kIOError,
    kNumerical,  // a numerical failure (indefinite matrix, non-convergence)
  };

  Status() = default;
  static Status Ok() { return Status(); }
  static Status NotFound(std::string_view message) { return Status(Code::kNotFound, message); }
  static Status Corruption(std::string_view message) { return Status(Code::kCorruption, message); }
  static Status NotSupported(std::string_view message) {
    return Status(Code::kNotSupported, message);
  }
  static Status InvalidArgument(std::string_view message) {
    return Status(Code::kInvalidArgument, message);
  }
  static Status IOError(std::string_view message) { return Status(Code::kIOError, message); }
  static Status Numerical(std::string_view message) { return Status(Code::kNumerical, message); }

  bool ok() const { return code_ == Code::kOk; }
  Code code() const { return code_; }
  const std::string& message() const { return message_; }
  bool IsNotFound() const { return code_ == Code::kNotFound; }
  bool IsCorruption() const { return code_ == Code::kCorruption; }
  bool IsInvalidArgument() const { return code_ == Code::kInvalidArgument; }
  bool IsIOError() const { return code_ == Code::kIOError; }
  bool IsNotSupported() const { return code_ == Code::kNotSupported; }
  bool IsNumerical() const { return code_ == Code::kNumerical; }

  // "Corruption: <message>", or "OK".
  std::string ToString() const;

  // Returns a status with the same code and "context: message".
  Status WithContext(std::string_view context) const;

 private:
  Status(Code code, std::string_view message) : code_(code), message_(message) {}
  Code code_ = Code::kOk;
  std::string message_;
};

// Either a value or a non-OK Status.
template <typename T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(const Status& status) : status_(status) {  // NOLINT: implicit by design
    GS_CHECK(!status_.ok());
  }
  StatusOr(Status&& status) : status_(std::move(status)) {  // NOLINT
    GS_CHECK(!status_.ok());
  }
  StatusOr(const T& value) : value_(value) {}        // NOLINT
  StatusOr(T&& value) : value_(std::move(value)) {}  // NOLINT

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  const T& value() const& {
    GS_CHECK(ok());
    return *value_;
  }
  T& value() & {
    GS_CHECK(ok());
    return *value_;
  }
  T&& value() && {
    GS_CHECK(ok());
    return std::move(*value_);
  }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

 private:
  Status status_;
  std::optional<T> value_;
};

}  // namespace graphslam

// Returns early from the enclosing function if `expr` is not OK.
#define GS_RETURN_IF_ERROR(expr)                 \
  do {                                           \
    ::graphslam::Status gs_status_ = (expr);     \
    if (!gs_status_.ok()) return gs_status_;     \
  } while (0)

#define GS_STATUS_CONCAT_INNER(a, b) a##b
#define GS_STATUS_CONCAT(a, b) GS_STATUS_CONCAT_INNER(a, b)
// `GS_ASSIGN_OR_RETURN(auto x, F());` declares x from a StatusOr or returns its error.
#define GS_ASSIGN_OR_RETURN(lhs, expr) \
  GS_ASSIGN_OR_RETURN_IMPL(GS_STATUS_CONCAT(gs_statusor_, __LINE__), lhs, expr)
#define GS_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                             \
  if (!tmp.ok()) return tmp.status();            \
  lhs = std::move(tmp).value()
