// UTF-8 checks (utf8.h).
#include "format/utf8.h"

#include <utility>

namespace skinspheres::runtime::internal {

namespace {

// The UTF-8 sequence at s[k]: {length, valid}. An invalid one's length is its maximal subpart
// (the lead byte and the continuation bytes that fit it, at least 1), which gets one U+FFFD.
// Shortest forms only, no surrogates, nothing above U+10FFFF.
std::pair<size_t, bool> Utf8Sequence(std::string_view s, size_t k) {
  const auto byte = [&](size_t i) { return static_cast<unsigned char>(s[i]); };
  const unsigned char c = byte(k);
  size_t len = 0;
  unsigned char lo = 0x80, hi = 0xBF;  // the range of the second byte
  if (c < 0x80) return {1, true};
  if (c >= 0xC2 && c <= 0xDF)
    len = 2;
  else if (c >= 0xE0 && c <= 0xEF)
    len = 3, lo = c == 0xE0 ? 0xA0 : 0x80, hi = c == 0xED ? 0x9F : 0xBF;
  else if (c >= 0xF0 && c <= 0xF4)
    len = 4, lo = c == 0xF0 ? 0x90 : 0x80, hi = c == 0xF4 ? 0x8F : 0xBF;
  else
    return {1, false};
  for (size_t i = 1; i < len; ++i) {
    const bool fits = k + i < s.size() && byte(k + i) >= (i == 1 ? lo : 0x80) && byte(k + i) <= (i == 1 ? hi : 0xBF);
    if (!fits) return {i, false};
  }
  return {len, true};
}

}  // namespace

size_t ValidUtf8Prefix(std::string_view s) {
  size_t k = 0;
  for (std::pair<size_t, bool> seq; k < s.size() && (seq = Utf8Sequence(s, k)).second;) k += seq.first;
  return k;
}

std::string ValidUtf8(std::string_view s) {
  if (ValidUtf8Prefix(s) == s.size()) return std::string(s);
  std::string out;
  for (size_t k = 0; k < s.size();) {
    const auto [length, valid] = Utf8Sequence(s, k);
    if (valid)
      out.append(s.substr(k, length));
    else
      out += "\xEF\xBF\xBD";
    k += length;
  }
  return out;
}

}  // namespace skinspheres::runtime::internal
