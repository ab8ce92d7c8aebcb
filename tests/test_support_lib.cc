// The test helpers that need the offline fitter (test_support.h, SKINSPHERES_TEST_WITH_LIB).
#include "skinspheres/lib/character/builtin_character.h"
#include "test_support.h"

namespace skinspheres::test {

const lib::RawCharacter& BuiltinCharacter() {
  static const lib::RawCharacter c = lib::MakeBuiltinCharacter();
  return c;
}

}  // namespace skinspheres::test
