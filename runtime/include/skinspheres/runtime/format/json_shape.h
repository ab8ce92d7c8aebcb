// The JSON shape check every JSON reader (the runtime's sphere sets, the fitter's glTF, joint maps
// and part files) runs before parsing. Pure function of its input, any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace skinspheres::runtime {

// The shape of JSON text, from one linear pass that skips strings (escapes included), with no
// recursion, whatever the text (malformed text gives some shape; the parser then refuses it):
// the deepest nesting of arrays and objects, and `values`: the arrays, objects and commas, at
// least half the number of values and at most their number plus one. nlohmann::json parses deep text without recursion
// but copies, compares and dumps it recursively, and holds ~100 bytes per value: a reader checks
// both before parsing.
struct JsonShape {
  size_t depth = 0;
  uint64_t values = 0;  // arrays + objects + commas outside strings
};
JsonShape ScanJson(std::string_view text);
inline constexpr size_t kMaxJsonDepth = 128;

}  // namespace skinspheres::runtime
