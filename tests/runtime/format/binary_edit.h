// Editing an encoded binary sphere set in the format tests (sphere_set_binary.h): values read and
// written in place, the checksum made valid again (so that the structural checks see the edit), and
// where a section's table entry is.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "skinspheres/runtime/format/sphere_set_binary.h"

namespace skinspheres::runtime::test_binary {

using Bytes = std::vector<std::byte>;

inline uint32_t Get32(const Bytes& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}
inline uint64_t Get64(const Bytes& b, size_t at) {
  uint64_t v;
  std::memcpy(&v, b.data() + at, 8);
  return v;
}
inline void Put32(Bytes& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); }
inline void Put64(Bytes& b, size_t at, uint64_t v) { std::memcpy(b.data() + at, &v, 8); }
inline void FixChecksum(Bytes& b) { Put64(b, 8, Xxh64(std::span<const std::byte>(b).subspan(16))); }

// Byte offset of section `id`'s table entry, 0 when the file has none.
inline size_t FindEntry(const Bytes& b, SphereSetSection id) {
  const uint32_t count = Get32(b, 32);
  for (uint32_t k = 0; k < count; ++k) {
    const size_t at = kSphereSetBinaryHeaderSize + k * kSphereSetBinarySectionEntrySize;
    if (Get32(b, at) == static_cast<uint32_t>(id)) return at;
  }
  return 0;
}

// The same for a section that must be present (a test failure otherwise).
inline size_t EntryOf(const Bytes& b, SphereSetSection id) {
  const size_t at = FindEntry(b, id);
  if (at == 0) ADD_FAILURE() << "no section " << static_cast<uint32_t>(id);
  return at;
}

}  // namespace skinspheres::runtime::test_binary
