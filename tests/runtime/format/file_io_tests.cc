// Tests for the runtime's file helpers (runtime/file_io.h), which every reader and writer of the
// library and the tool goes through: the JSON pre-scan that bounds nesting before parsing, reads
// capped before allocating (regular files only; /proc files of size 0 read to their end), and
// writes checked through the close. The hostile inputs they exist for are tested at the readers
// (tests/lib/io/hostile_input_tests.cc, sphere_set_hostile_tests.cc).
#include "skinspheres/runtime/format/file_io.h"

#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "test_support.h"

namespace skinspheres::runtime {
namespace {

TEST(FileIo, ScanJsonCountsDepthAndValuesOutsideStrings) {
  EXPECT_EQ(ScanJson("").depth, 0u);
  EXPECT_EQ(ScanJson("[[1,2],{\"a\":[3]}]").depth, 3u);
  EXPECT_EQ(ScanJson("[[1,2],{\"a\":[3]}]").values, 6u);       // 4 arrays and objects, 2 commas
  EXPECT_EQ(ScanJson("[\"[[[\\\"[[[\", \"]]]\"]").depth, 1u);  // brackets and escaped quotes in strings
  EXPECT_EQ(ScanJson(std::string(100000, '[')).depth, 100000u);
}

TEST(FileIo, ReadRegularFileCapsWhatItReads) {
  const auto dir = test::TempDir("file_io_read");
  const auto path = dir / "ten.txt";
  std::ofstream(path, std::ios::binary) << "0123456789";
  auto ten = ReadRegularFile(path, 10);
  ASSERT_TRUE(ten.ok()) << ten.error().message;
  EXPECT_EQ(*ten, "0123456789");
  auto nine = ReadRegularFile(path, 9, "test file");
  ASSERT_FALSE(nine.ok());
  EXPECT_EQ(nine.error().message, path.string() + ": is 10 bytes; a test file may be at most 9 bytes");
  // /proc files report size 0 and are read to their end, within the cap.
  auto proc = ReadRegularFile("/proc/self/status", 1 << 20);
  ASSERT_TRUE(proc.ok()) << proc.error().message;
  EXPECT_NE(proc->find("Name:"), std::string::npos);
  EXPECT_FALSE(ReadRegularFile("/proc/self/status", 16).ok());
  auto prefix = ReadRegularFilePrefix(path, 4);
  ASSERT_TRUE(prefix.ok());
  EXPECT_EQ(std::string(prefix->begin(), prefix->end()), "0123");
  EXPECT_EQ(ReadRegularFilePrefix(path, 11).error().code, ErrorCode::kFormatRejected);
}

TEST(FileIo, WritesAreCheckedThroughTheClose) {
  // /dev/full accepts the open and the buffered write, and fails the flush: never reported as written.
  const auto err = WriteWholeFile("/dev/full", "some bytes");
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->message, "/dev/full: write failed (No space left on device)");
  CheckedFileWriter out("/dev/full");
  for (int k = 0; k < 1000; ++k) out.Write(std::string(1000, 'x'));  // fails once the stdio buffer flushes
  EXPECT_FALSE(out.ok());
  EXPECT_TRUE(out.Close().has_value());
  const auto dir = test::TempDir("file_io_write");
  EXPECT_TRUE(WriteWholeFile(dir / "no_such_dir" / "x", "x").has_value());
  EXPECT_FALSE(WriteWholeFile(dir / "ok.txt", "fine").has_value());
  EXPECT_EQ(*ReadRegularFile(dir / "ok.txt", 100), "fine");
}

}  // namespace
}  // namespace skinspheres::runtime
