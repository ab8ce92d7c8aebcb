// Result / ErrorCode (error.h): value() on an error is a contract violation that stops the program
// with the error's message (never a std::bad_variant_access), and every code has a name.
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "skinspheres/runtime/error.h"
#include "test_support.h"

namespace skinspheres {
namespace {

Result<int> Parse(bool good) {
  if (good) return 7;
  return MakeError(ErrorCode::kInvalidData, "level.ssb: section 3 is truncated");
}

TEST(ResultTest, ValueAndErrorWhenTheyAreThere) {
  Result<int> good = Parse(true);
  ASSERT_TRUE(good.ok());
  EXPECT_EQ(good.value(), 7);
  EXPECT_EQ(*good, 7);
  Result<int> bad = Parse(false);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidData);
  Result<std::string> moved = std::string("abc");
  EXPECT_EQ(std::move(moved).value(), "abc");
}

using ResultDeathTest = ::testing::Test;

TEST_F(ResultDeathTest, ValueOfAnErrorStopsWithItsMessage) {
  // threadsafe re-executes the test program: right beside TBB's threads, impossible under
  // qemu-user (no binfmt: the child cannot exec an aarch64 program), where no TBB runs either.
  GTEST_FLAG_SET(death_test_style, test::DefaultIsTbb() ? "threadsafe" : "fast");
  EXPECT_DEATH(
      {
        Result<int> bad = Parse(false);
        std::printf("%d\n", bad.value());
      },
      "skinspheres: Result::value\\(\\) called on an error: level.ssb: section 3 is truncated");
  EXPECT_DEATH(
      {
        Result<std::string> bad = MakeError(ErrorCode::kFileNotFound, "x.json: file not found");
        std::printf("%zu\n", bad->size());
      },
      "called on an error: x.json: file not found");
  EXPECT_DEATH(
      {
        const Result<int> good = Parse(true);
        std::printf("%d\n", static_cast<int>(good.error().code));
      },
      "skinspheres: Result::error\\(\\) called on a value");
}

TEST(ErrorCodeTest, EveryCodeHasItsOwnName) {
  std::set<std::string> names;
  for (int c = 0; c <= static_cast<int>(ErrorCode::kCheckFailed); ++c) {
    const std::string name = ToString(static_cast<ErrorCode>(c));
    EXPECT_NE(name, "unknown error code") << c;
    EXPECT_TRUE(names.insert(name).second) << name;
  }
  EXPECT_STREQ(ToString(ErrorCode::kOk), "ok");
  EXPECT_STREQ(ToString(ErrorCode::kFileNotFound), "file not found");
  EXPECT_STREQ(ToString(static_cast<ErrorCode>(1000)), "unknown error code");
}

}  // namespace
}  // namespace skinspheres
