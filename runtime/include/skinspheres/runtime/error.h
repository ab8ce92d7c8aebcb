// Error reporting for everything that reads input: a code for programs, a message for people.
// Messages name the input (file) and the problem in one line.
//
// Result<T> holds a value or an Error. Check ok() (or the bool conversion) before value(), *, ->:
// reading the value of a Result that holds an error, or the error of one that holds a value, is a
// contract violation, not a recoverable error. It never throws; it stops the program with one line
// on stderr naming the violation and the error's message ("skinspheres: Result::value() called on
// an error: <message>"), in every build type (an assert in debug builds, and the same check, one
// predictable branch, in release builds rather than undefined behaviour).
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>
#include <variant>

namespace skinspheres {

enum class ErrorCode {
  kOk = 0,
  kFileNotFound,
  kFileUnreadable,
  kFormatRejected,  // the reader (Assimp, JSON, binary) refused the file
  kInvalidData,     // read, but the content breaks a rule (NaN, weights, indices, ...)
  kVersionMismatch,
  kMismatchedAsset,  // a sphere set made for another character
  kInvalidArgument,
  kNotFound,     // a named thing (clip, joint) is not there
  kCheckFailed,  // a self-check failed (a triangle outside its sphere): a bug, not bad input
};

// A short lower-case name: "ok", "file not found", "file unreadable", "format rejected",
// "invalid data", "version mismatch", "mismatched asset", "invalid argument", "not found",
// "check failed"; "unknown error code" for a value outside the enum. A static string.
inline const char* ToString(ErrorCode code) {
  switch (code) {
    case ErrorCode::kOk: return "ok";
    case ErrorCode::kFileNotFound: return "file not found";
    case ErrorCode::kFileUnreadable: return "file unreadable";
    case ErrorCode::kFormatRejected: return "format rejected";
    case ErrorCode::kInvalidData: return "invalid data";
    case ErrorCode::kVersionMismatch: return "version mismatch";
    case ErrorCode::kMismatchedAsset: return "mismatched asset";
    case ErrorCode::kInvalidArgument: return "invalid argument";
    case ErrorCode::kNotFound: return "not found";
    case ErrorCode::kCheckFailed: return "check failed";
  }
  return "unknown error code";
}

struct Error {
  ErrorCode code = ErrorCode::kOk;
  std::string message;
};

namespace detail {
// The contract violation of Result: one line on stderr, then abort (never returns, never throws).
[[noreturn]] inline void ResultContractViolation(const char* what, const std::string& message) {
  std::fprintf(stderr, "skinspheres: %s%s%s\n", what, message.empty() ? "" : ": ", message.c_str());
  std::fflush(stderr);
  std::abort();
}
}  // namespace detail

// Result<T>: a value or an Error (C++20 has no std::expected).
template <typename T>
class Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}  // NOLINT(google-explicit-constructor)
  bool ok() const { return v_.index() == 0; }
  explicit operator bool() const { return ok(); }
  // Precondition ok(): see the header comment.
  T& value() & { return *Value(); }
  const T& value() const& { return *Value(); }
  T&& value() && { return std::move(*Value()); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  // Precondition !ok().
  const Error& error() const {
    const Error* e = std::get_if<1>(&v_);
    if (e == nullptr) detail::ResultContractViolation("Result::error() called on a value", "");
    return *e;
  }

 private:
  T* Value() {
    T* v = std::get_if<0>(&v_);
    if (v == nullptr)
      detail::ResultContractViolation("Result::value() called on an error", std::get_if<1>(&v_)->message);
    return v;
  }
  const T* Value() const { return const_cast<Result*>(this)->Value(); }

  std::variant<T, Error> v_;
};

inline Error MakeError(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

}  // namespace skinspheres
