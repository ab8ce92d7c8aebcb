// Error reporting for everything that reads input: a code for programs, a message for people.
// Messages name the input (file) and the problem in one line.
#pragma once

#include <string>
#include <utility>
#include <variant>

namespace skinspheres {

enum class ErrorCode {
  kOk = 0,
  kFileNotFound,
  kFileUnreadable,
  kFormatRejected,      // the reader (Assimp, JSON) refused the file
  kInvalidData,         // read, but the content breaks a rule (NaN, weights, indices, ...)
  kVersionMismatch,
  kMismatchedAsset,     // a sphere set made for another character
  kInvalidArgument,
  kNotFound,            // a named thing (clip, joint) is not there
  kCheckFailed,         // a self-check failed (a triangle outside its sphere): a bug, not bad input
};

struct Error {
  ErrorCode code = ErrorCode::kOk;
  std::string message;
};

// Result<T>: a value or an Error (C++20 has no std::expected).
template <typename T>
class Result {
 public:
  Result(T value) : v_(std::move(value)) {}          // NOLINT(google-explicit-constructor)
  Result(Error error) : v_(std::move(error)) {}      // NOLINT(google-explicit-constructor)
  bool ok() const { return std::holds_alternative<T>(v_); }
  explicit operator bool() const { return ok(); }
  T& value() & { return std::get<T>(v_); }
  const T& value() const& { return std::get<T>(v_); }
  T&& value() && { return std::get<T>(std::move(v_)); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  const Error& error() const { return std::get<Error>(v_); }

 private:
  std::variant<T, Error> v_;
};

inline Error MakeError(ErrorCode code, std::string message) { return Error{code, std::move(message)}; }

}  // namespace skinspheres
