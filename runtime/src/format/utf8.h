// UTF-8 checks for names read from and written to files. Internal to the runtime library.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace skinspheres::runtime::internal {

// The length of the valid UTF-8 prefix of s (s.size() when all of it is valid): shortest forms
// only, no surrogates, nothing above U+10FFFF.
size_t ValidUtf8Prefix(std::string_view s);

// s with each invalid sequence (its maximal subpart: the lead byte and the continuation bytes that
// fit it) replaced by U+FFFD, as the JSON writer (nlohmann::json's error_handler_t::replace) does:
// for names taken from a file's bytes (a path, a Latin-1 FBX name).
std::string ValidUtf8(std::string_view s);

}  // namespace skinspheres::runtime::internal
