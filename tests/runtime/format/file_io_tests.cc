// Tests for the runtime's file helpers (format/file_io.h), which every reader and writer of the
// library and the tool goes through, on POSIX and Windows alike: the JSON pre-scan that bounds
// nesting before parsing, reads capped before allocating (regular files only; /proc files of size 0
// read to their end), bytes unchanged (binary mode), UTF-8 names, and writes checked through the
// close. The hostile inputs they exist for are tested at the readers
// (tests/lib/io/hostile_input_tests.cc, sphere_set_hostile_tests.cc).
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <string>

#include "skinspheres/runtime/format/file_io.h"
#include "skinspheres/runtime/format/json_shape.h"
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
  EXPECT_EQ(nine.error().message, PathText(path) + ": is 10 bytes; a test file may be at most 9 bytes");
  auto prefix = ReadRegularFilePrefix(path, 4);
  ASSERT_TRUE(prefix.ok());
  EXPECT_EQ(std::string(prefix->begin(), prefix->end()), "0123");
  EXPECT_EQ(ReadRegularFilePrefix(path, 11).error().code, ErrorCode::kFormatRejected);
}

// Every byte value survives a write and a read: binary mode on every platform (Windows' text mode
// would turn \n into \r\n and stop reading at \x1a).
TEST(FileIo, BytesRoundTripUnchanged) {
  const auto dir = test::TempDir("file_io_bytes");
  std::string bytes;
  for (int round = 0; round < 3; ++round) {
    for (int c = 0; c < 256; ++c) bytes += static_cast<char>(c);
  }
  bytes += "\r\n\n\x1a\r";
  ASSERT_FALSE(WriteWholeFile(dir / "all.bin", bytes).has_value());
  auto back = ReadRegularFile(dir / "all.bin", 1 << 20);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(*back, bytes);
  auto as_bytes = ReadRegularFileBytes(dir / "all.bin", 1 << 20);
  ASSERT_TRUE(as_bytes.ok());
  EXPECT_EQ(as_bytes->size(), bytes.size());
  EXPECT_EQ(std::memcmp(as_bytes->data(), bytes.data(), bytes.size()), 0);
}

// Names outside ASCII, written and read back, and named in messages as UTF-8.
TEST(FileIo, NonAsciiPathsWorkAndAreNamedAsUtf8) {
  const auto dir = test::TempDir("file_io_names");
  const std::filesystem::path name(std::u8string(u8"\u00e9t\u00e9 \u5b57.bin"));
  ASSERT_FALSE(WriteWholeFile(dir / name, "x").has_value());
  auto read = ReadRegularFile(dir / name, 10);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(*read, "x");
  auto capped = ReadRegularFile(dir / name, 0);
  ASSERT_FALSE(capped.ok());
  EXPECT_NE(capped.error().message.find("\xc3\xa9t\xc3\xa9 \xe5\xad\x97.bin: is 1 bytes"), std::string::npos)
      << capped.error().message;
}

// What is not a regular file is refused before a byte is read, in one line naming it: a missing
// file, a directory, a pipe nobody writes (a blocking open would hang the test), a device.
TEST(FileIo, OnlyRegularFilesAreRead) {
  const auto dir = test::TempDir("file_io_refuse");
  const test::TestPipe pipe(dir, "pipe");
  ASSERT_TRUE(pipe.ok());
  struct Case {
    std::filesystem::path path;
    ErrorCode code;
    const char* needle;
  };
  for (const Case& c :
       {Case{dir / "missing.txt", ErrorCode::kFileNotFound, "file not found"},
        Case{dir, ErrorCode::kFileUnreadable, "is a directory"}, Case{pipe.path(), ErrorCode::kFileUnreadable, "pipe"},
        Case{test::DeviceNotAFile(), ErrorCode::kFileUnreadable, "is a device"}}) {
    auto read = ReadRegularFile(c.path, 1 << 20);
    ASSERT_FALSE(read.ok()) << PathText(c.path);
    EXPECT_EQ(read.error().code, c.code) << read.error().message;
    EXPECT_EQ(read.error().message.rfind(PathText(c.path) + ": ", 0), 0u) << read.error().message;
    EXPECT_NE(read.error().message.find(c.needle), std::string::npos) << read.error().message;
    EXPECT_EQ(read.error().message.find('\n'), std::string::npos) << read.error().message;
  }
  EXPECT_EQ(ReadRegularFile("", 10).error().code, ErrorCode::kInvalidArgument);
}

TEST(FileIo, WritesAreChecked) {
  const auto dir = test::TempDir("file_io_write");
  EXPECT_TRUE(WriteWholeFile(dir / "no_such_dir" / "x", "x").has_value());
  const auto onto_dir = WriteWholeFile(dir, "x");  // a directory is not overwritten
  ASSERT_TRUE(onto_dir.has_value());
  EXPECT_EQ(onto_dir->message.rfind(PathText(dir) + ": ", 0), 0u) << onto_dir->message;
  EXPECT_FALSE(WriteWholeFile(dir / "ok.txt", "fine").has_value());
  EXPECT_EQ(*ReadRegularFile(dir / "ok.txt", 100), "fine");
}

#if !defined(_WIN32)
// POSIX only: /proc files report size 0 and are read to their end, within the cap; /dev/full
// accepts the open and the buffered write, and fails the flush: never reported as written.
TEST(FileIo, ProcFilesAreReadToTheirEndAndAFullDiskIsReported) {
  auto proc = ReadRegularFile("/proc/self/status", 1 << 20);
  ASSERT_TRUE(proc.ok()) << proc.error().message;
  EXPECT_NE(proc->find("Name:"), std::string::npos);
  EXPECT_FALSE(ReadRegularFile("/proc/self/status", 16).ok());
  const auto err = WriteWholeFile("/dev/full", "some bytes");
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->message, "/dev/full: write failed (No space left on device)");
  CheckedFileWriter out("/dev/full");
  for (int k = 0; k < 1000; ++k) out.Write(std::string(1000, 'x'));  // fails once the stdio buffer flushes
  EXPECT_FALSE(out.ok());
  EXPECT_TRUE(out.Close().has_value());
}
#endif

}  // namespace
}  // namespace skinspheres::runtime
