// What every fuzz target asserts beyond "no crash": a check that fails aborts with a message,
// so libFuzzer (and the replay tests) report it as a crash with the input that caused it.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>

#include "skinspheres/runtime/error.h"

namespace skinspheres::fuzz {

[[noreturn]] inline void Violated(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz property violated: %s: %s\n", what, detail.c_str());
  std::abort();
}

#define SKINSPHERES_FUZZ_CHECK(cond, detail)                     \
  do {                                                           \
    if (!(cond)) ::skinspheres::fuzz::Violated(#cond, (detail)); \
  } while (0)

// The error contract: one line that starts with the input's name, never a self-check failure
// (kCheckFailed is a bug, not bad input).
inline void CheckError(const Error& e, const std::string& name) {
  SKINSPHERES_FUZZ_CHECK(e.code != ErrorCode::kOk, e.message);
  SKINSPHERES_FUZZ_CHECK(e.code != ErrorCode::kCheckFailed, e.message);
  SKINSPHERES_FUZZ_CHECK(e.message.rfind(name + ": ", 0) == 0, e.message);
  SKINSPHERES_FUZZ_CHECK(e.message.find('\n') == std::string::npos, e.message);
}

}  // namespace skinspheres::fuzz
