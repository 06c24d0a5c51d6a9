// Status values for ordinary outcomes (bad input, missing files, infeasible
// problems). Library code returns these instead of throwing; applications map
// them to exit codes (see docs/contracts.md).
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace quadhand::core {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,  // malformed input, bad option, inconsistent data
  kNotFound,         // a file or a named entity does not exist
  kIoError,          // a file exists but cannot be read or written
  kInfeasible,       // the input is valid but no solution satisfies it
  kInternal,         // a bug or an unexpected library failure
};

// Name of a code, e.g. "invalid argument".
const char* StatusCodeName(StatusCode code);

class Status {
 public:
  Status() = default;  // OK
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return Status(); }
  static Status InvalidArgument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
  static Status NotFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
  static Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
  static Status Infeasible(std::string m) { return {StatusCode::kInfeasible, std::move(m)}; }
  static Status Internal(std::string m) { return {StatusCode::kInternal, std::move(m)}; }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }

  // A copy whose message is "<prefix>: <message>", for adding context such as a file name.
  Status WithPrefix(const std::string& prefix) const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

// A value or the Status that explains why there is none.
template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {}  // NOLINT: implicit by design

  bool ok() const { return value_.has_value(); }
  const Status& status() const { return status_; }
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() { return *value_; }
  const T& operator*() const { return *value_; }

 private:
  std::optional<T> value_;
  Status status_ = Status::Internal("Result holds no value");
};

}  // namespace quadhand::core

// Returns the Status of `expr` from the enclosing function if it is not OK.
#define QUADHAND_RETURN_IF_ERROR(expr)              \
  do {                                              \
    ::quadhand::core::Status _qh_status = (expr);   \
    if (!_qh_status.ok()) return _qh_status;        \
  } while (false)
