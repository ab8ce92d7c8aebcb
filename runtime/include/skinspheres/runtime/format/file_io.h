// Whole-file reading and checked writing for paths a user hands in (untrusted). POSIX and Windows
// (wide paths, binary mode) alike.
//
// Reading refuses, before it reads a byte, anything that is not a regular file: a directory, a
// FIFO or pipe (it would block until a writer came), a device (/dev/zero never ends; NUL, CON on
// Windows) or a socket. On POSIX the file is opened non-blocking, so a FIFO is refused at once
// rather than waited on; on Windows GetFileType tells a pipe or a device from a file. A file larger
// than the caller's limit is refused from its size, before anything is allocated, and again if it
// grows past the limit while being read (/proc files report size 0).
//
// Writing checks every write, the flush and the close (a full disk or /dev/full fails at the
// flush or the close, never silently), and reports the first failure in one line. The output is
// opened non-blocking, so a FIFO nobody reads is refused at once instead of waited on (a pipe
// with a reader is written as usual).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "skinspheres/runtime/error.h"

namespace skinspheres::runtime {

// A path as UTF-8 text, for messages, on every platform (Windows paths are wide; their string()
// would throw on a name outside the code page).
std::string PathText(const std::filesystem::path& path);

// The whole of the regular file at `path`, at most `max_bytes` long. `what` names the kind of
// file in the size message ("a sphere set may be at most ... bytes"). Errors are one line
// "<path>: <problem>": kFileNotFound (missing), kFileUnreadable (a directory, FIFO, device or
// socket; no permission; an I/O error), kFormatRejected (larger than max_bytes).
Result<std::string> ReadRegularFile(const std::filesystem::path& path, uint64_t max_bytes,
                                    std::string_view what = "file");
// The same into bytes (a binary file): the buffer comes from operator new, so it is aligned for
// any fundamental type (16 bytes on x86-64).
Result<std::vector<std::byte>> ReadRegularFileBytes(const std::filesystem::path& path, uint64_t max_bytes,
                                                    std::string_view what = "file");

// The first `length` bytes of the regular file at `path` (a glTF's external buffer: the file
// may be longer). Refuses what ReadRegularFile refuses; kFormatRejected when the file is shorter
// (checked from its size before anything is allocated).
Result<std::vector<uint8_t>> ReadRegularFilePrefix(const std::filesystem::path& path, uint64_t length);

// Creates or truncates `path` and writes `bytes` to it, checked through the close. Error
// (kFileUnreadable): "<path>: cannot open for writing (reason)", "<path>: is a FIFO (named pipe)
// nobody reads: cannot write to it" or "<path>: write failed (reason)".
// A failed write may leave a partial file: the path is never deleted (it may be a device).
std::optional<Error> WriteWholeFile(const std::filesystem::path& path, std::string_view bytes);

// A file written piece by piece (one JSON line per frame, ...), checked like WriteWholeFile:
// Write() after a failure does nothing; Close() returns the first failure (open, write, flush or
// close). Destroying an open writer closes it and drops any error: call Close().
class CheckedFileWriter {
 public:
  explicit CheckedFileWriter(const std::filesystem::path& path);
  CheckedFileWriter(const CheckedFileWriter&) = delete;
  CheckedFileWriter& operator=(const CheckedFileWriter&) = delete;
  ~CheckedFileWriter();

  bool ok() const { return !error_.has_value(); }
  // Appends `bytes` (buffered). False once any step has failed.
  bool Write(std::string_view bytes);
  // Flushes and closes; the first failure of any step, or std::nullopt when all went through.
  std::optional<Error> Close();

 private:
  void FailWith(const char* step, int errno_value);
  std::filesystem::path path_;
  std::optional<Error> error_;  // before file_: the open sets it
  std::FILE* file_ = nullptr;
};

// `message` as one line: control characters (a newline or NUL in a quoted joint, part or file
// name) written as escapes ("\n", "\x00"). Where an error leaves the library (the C API's last
// error, the tool's stderr line), so a name from a file never splits the line.
std::string OneLine(std::string message);

// The JSON shape check every JSON reader runs before parsing: json_shape.h.

}  // namespace skinspheres::runtime
