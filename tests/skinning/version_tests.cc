// skinspheres/version.h: the macros come from the project's VERSION, and the library reports the
// version it was built as.
#include <gtest/gtest.h>

#include <string>

#include "skinspheres/skinning/parallel_for.h"
#include "skinspheres/version.h"

namespace skinspheres {
namespace {

TEST(VersionTest, MacrosAndLibraryAgree) {
  EXPECT_EQ(SKINSPHERES_VERSION,
            SKINSPHERES_VERSION_MAJOR * 10000 + SKINSPHERES_VERSION_MINOR * 100 + SKINSPHERES_VERSION_PATCH);
  EXPECT_EQ(std::string(SKINSPHERES_VERSION_STRING), std::to_string(SKINSPHERES_VERSION_MAJOR) + "." +
                                                         std::to_string(SKINSPHERES_VERSION_MINOR) + "." +
                                                         std::to_string(SKINSPHERES_VERSION_PATCH));
  EXPECT_EQ(LibraryVersion(), SKINSPHERES_VERSION);
  EXPECT_STREQ(LibraryVersionString(), SKINSPHERES_VERSION_STRING);
  EXPECT_GT(LibraryVersion(), 0);
}

TEST(VersionTest, TheBuildSaysWhetherTheDefaultLoopUsesTbb) {
#if SKINSPHERES_TEST_EXPECT_TBB
  EXPECT_TRUE(DefaultParallelForUsesTbb());
#else
  EXPECT_FALSE(DefaultParallelForUsesTbb());
#endif
}

}  // namespace
}  // namespace skinspheres
