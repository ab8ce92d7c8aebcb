// Whole-file reading and checked writing (file_io.h). The operating system's part sits in one
// place per platform: POSIX (open, fstat, read; non-blocking opens so that a FIFO is refused, not
// waited on) and Win32 (CreateFileW on the wide path, GetFileType to refuse pipes and devices,
// ReadFile; writing through _wfopen in binary mode). Everything else is shared.
#include "skinspheres/runtime/format/file_io.h"

#if defined(_WIN32)
#ifndef WIN32_LEAN_AND_MEAN
#define WIN32_LEAN_AND_MEAN
#endif
#ifndef NOMINMAX
#define NOMINMAX
#endif
#include <windows.h>
#else
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#endif

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

namespace skinspheres::runtime {
namespace {

Error FileError(ErrorCode code, const std::filesystem::path& path, const std::string& problem) {
  return MakeError(code, PathText(path) + ": " + problem);
}

std::string Reason(int errno_value) { return std::strerror(errno_value); }

#if defined(_WIN32)
// ------------------------------------------------------------------------------------ Win32

std::string WindowsReason(DWORD code) {
  char text[256] = {};
  const DWORD n = FormatMessageA(FORMAT_MESSAGE_FROM_SYSTEM | FORMAT_MESSAGE_IGNORE_INSERTS, nullptr, code,
                                 MAKELANGID(LANG_ENGLISH, SUBLANG_DEFAULT), text, sizeof(text), nullptr);
  std::string reason(text, n);
  while (!reason.empty() && (reason.back() == '\n' || reason.back() == '\r' || reason.back() == '.')) reason.pop_back();
  if (reason.empty()) reason = "Windows error " + std::to_string(code);
  return reason;
}

// A file opened for reading; closed on every path out.
class InputFile {
 public:
  InputFile() = default;
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  ~InputFile() {
    if (handle_ != INVALID_HANDLE_VALUE) CloseHandle(handle_);
  }

  // Opens `path` when it is a regular file (not a directory, a pipe or a device such as NUL or
  // CON); `size` gets its size.
  std::optional<Error> Open(const std::filesystem::path& path, uint64_t* size) {
    if (path.empty()) return MakeError(ErrorCode::kInvalidArgument, "empty path: no file named");
    const DWORD attributes = GetFileAttributesW(path.c_str());
    if (attributes != INVALID_FILE_ATTRIBUTES && (attributes & FILE_ATTRIBUTE_DIRECTORY) != 0) {
      return FileError(ErrorCode::kFileUnreadable, path, "is a directory, not a file");
    }
    handle_ = CreateFileW(path.c_str(), GENERIC_READ, FILE_SHARE_READ | FILE_SHARE_WRITE, nullptr, OPEN_EXISTING,
                          FILE_ATTRIBUTE_NORMAL, nullptr);
    if (handle_ == INVALID_HANDLE_VALUE) {
      const DWORD e = GetLastError();
      if (e == ERROR_FILE_NOT_FOUND || e == ERROR_PATH_NOT_FOUND || e == ERROR_INVALID_NAME) {
        return FileError(ErrorCode::kFileNotFound, path, "file not found");
      }
      if (e == ERROR_ACCESS_DENIED)
        return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (permission denied)");
      if (e == ERROR_PIPE_BUSY) return FileError(ErrorCode::kFileUnreadable, path, "is a pipe, not a regular file");
      return FileError(ErrorCode::kFileUnreadable, path, "cannot be opened for reading (" + WindowsReason(e) + ")");
    }
    switch (GetFileType(handle_)) {
      case FILE_TYPE_DISK: break;
      case FILE_TYPE_PIPE: return FileError(ErrorCode::kFileUnreadable, path, "is a pipe, not a regular file");
      case FILE_TYPE_CHAR: return FileError(ErrorCode::kFileUnreadable, path, "is a device, not a regular file");
      default: return FileError(ErrorCode::kFileUnreadable, path, "is not a regular file");
    }
    LARGE_INTEGER bytes{};
    if (!GetFileSizeEx(handle_, &bytes)) {
      return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (" + WindowsReason(GetLastError()) + ")");
    }
    *size = static_cast<uint64_t>(std::max<LONGLONG>(bytes.QuadPart, 0));
    return std::nullopt;
  }

  // Reads until `out` is full or the file ends: the number of bytes read, or -1 (reason() says why).
  int64_t ReadUpTo(char* out, size_t n) {
    size_t have = 0;
    while (have < n) {
      const DWORD want = static_cast<DWORD>(std::min<size_t>(n - have, DWORD{1} << 30));
      DWORD got = 0;
      if (!ReadFile(handle_, out + have, want, &got, nullptr)) {
        error_ = GetLastError();
        return -1;
      }
      if (got == 0) break;
      have += got;
    }
    return static_cast<int64_t>(have);
  }
  std::string reason() const { return WindowsReason(error_); }

 private:
  HANDLE handle_ = INVALID_HANDLE_VALUE;
  DWORD error_ = 0;
};

// The output stream of CheckedFileWriter: binary mode, the wide path.
std::FILE* OpenForWriting(const std::filesystem::path& path, std::optional<Error>* error) {
  const DWORD attributes = GetFileAttributesW(path.c_str());
  if (attributes != INVALID_FILE_ATTRIBUTES && (attributes & FILE_ATTRIBUTE_DIRECTORY) != 0) {
    *error = FileError(ErrorCode::kFileUnreadable, path, "is a directory: cannot write to it");
    return nullptr;
  }
  std::FILE* file = _wfopen(path.c_str(), L"wb");
  if (file == nullptr)
    *error = FileError(ErrorCode::kFileUnreadable, path, "cannot open for writing (" + Reason(errno) + ")");
  return file;
}

#else
// ------------------------------------------------------------------------------------ POSIX

const char* NotRegular(mode_t mode) {
  if (S_ISDIR(mode)) return "is a directory, not a file";
  if (S_ISFIFO(mode)) return "is a FIFO (named pipe), not a regular file";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "is a device, not a regular file";
  if (S_ISSOCK(mode)) return "is a socket, not a regular file";
  return "is not a regular file";
}

// A file opened for reading; closed on every path out.
class InputFile {
 public:
  InputFile() = default;
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;
  ~InputFile() {
    if (fd_ >= 0) ::close(fd_);
  }

  // Opens `path` for reading when it is a regular file (non-blocking open, so a FIFO is refused
  // at once); `size` gets its size.
  std::optional<Error> Open(const std::filesystem::path& path, uint64_t* size) {
    if (path.empty()) return MakeError(ErrorCode::kInvalidArgument, "empty path: no file named");
    do {
      fd_ = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    } while (fd_ < 0 && errno == EINTR);
    if (fd_ < 0) {
      const int e = errno;
      if (e == ENOENT || e == ENOTDIR) return FileError(ErrorCode::kFileNotFound, path, "file not found");
      if (e == EACCES || e == EPERM)
        return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (permission denied)");
      return FileError(ErrorCode::kFileUnreadable, path, "cannot be opened for reading (" + Reason(e) + ")");
    }
    struct stat st {};
    if (::fstat(fd_, &st) != 0)
      return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (" + Reason(errno) + ")");
    if (!S_ISREG(st.st_mode)) return FileError(ErrorCode::kFileUnreadable, path, NotRegular(st.st_mode));
    *size = static_cast<uint64_t>(std::max<off_t>(st.st_size, 0));
    // A regular file never blocks; back to blocking reads so a slow disk is waited on, not an error.
    const int flags = ::fcntl(fd_, F_GETFL);
    if (flags >= 0) ::fcntl(fd_, F_SETFL, flags & ~O_NONBLOCK);
    return std::nullopt;
  }

  // read() until `out` is full or the file ends: the number of bytes read, or -1 (reason() says why).
  int64_t ReadUpTo(char* out, size_t n) {
    size_t have = 0;
    while (have < n) {
      const ssize_t got = ::read(fd_, out + have, n - have);
      if (got < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return -1;
      }
      if (got == 0) break;
      have += static_cast<size_t>(got);
    }
    return static_cast<int64_t>(have);
  }
  std::string reason() const { return Reason(error_); }

 private:
  int fd_ = -1;
  int error_ = 0;
};

// The output stream of CheckedFileWriter. Non-blocking open: a FIFO nobody reads fails at once
// (ENXIO) instead of waiting for a reader forever. Once open, writes block as usual (a pipe with a
// reader, a slow disk).
std::FILE* OpenForWriting(const std::filesystem::path& path, std::optional<Error>* error) {
  int fd = -1;
  do {
    fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NONBLOCK | O_CLOEXEC | O_NOCTTY, 0666);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int e = errno;
    struct stat st {};
    const bool fifo = e == ENXIO && ::stat(path.c_str(), &st) == 0 && S_ISFIFO(st.st_mode);
    *error = FileError(ErrorCode::kFileUnreadable, path,
                       fifo ? "is a FIFO (named pipe) nobody reads: cannot write to it"
                            : "cannot open for writing (" + Reason(e) + ")");
    return nullptr;
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  std::FILE* file = ::fdopen(fd, "wb");
  if (file == nullptr) {
    *error = FileError(ErrorCode::kFileUnreadable, path, "cannot open for writing (" + Reason(errno) + ")");
    ::close(fd);
  }
  return file;
}
#endif

// ReadRegularFile into any contiguous byte container with resize() (std::string, a byte vector).
template <typename Bytes>
Result<Bytes> ReadRegular(const std::filesystem::path& path, uint64_t max_bytes, std::string_view what) {
  InputFile f;
  uint64_t size = 0;
  if (auto err = f.Open(path, &size)) return *err;
  auto too_large = [&](uint64_t n, bool at_least) {
    return FileError(ErrorCode::kFormatRejected, path,
                     "is " + std::string(at_least ? "more than " : "") + std::to_string(n) + " bytes; a " +
                         std::string(what) + " may be at most " + std::to_string(max_bytes) + " bytes");
  };
  if (size > max_bytes) return too_large(size, false);
  // One spare byte: the read that finds the end lands there, so a file of the size fstat gave is
  // read without reallocating. A file longer than that (it grew, or /proc reports 0) is read on
  // in steps, never past max_bytes + 1.
  Bytes bytes;
  bytes.resize(static_cast<size_t>(size) + 1);
  size_t have = 0;
  for (;;) {
    const int64_t got = f.ReadUpTo(reinterpret_cast<char*>(bytes.data()) + have, bytes.size() - have);
    if (got < 0) return FileError(ErrorCode::kFileUnreadable, path, "read error (" + f.reason() + ")");
    have += static_cast<size_t>(got);
    if (have < bytes.size()) break;  // the end of the file
    if (have > max_bytes) return too_large(max_bytes, true);
    bytes.resize(have + std::min<uint64_t>(std::max<size_t>(have, 64 * 1024), max_bytes + 1 - have));
  }
  bytes.resize(have);
  return bytes;
}

}  // namespace

std::string PathText(const std::filesystem::path& path) {
  const std::u8string text = path.u8string();
  return std::string(reinterpret_cast<const char*>(text.data()), text.size());
}

Result<std::string> ReadRegularFile(const std::filesystem::path& path, uint64_t max_bytes, std::string_view what) {
  return ReadRegular<std::string>(path, max_bytes, what);
}

Result<std::vector<std::byte>> ReadRegularFileBytes(const std::filesystem::path& path, uint64_t max_bytes,
                                                    std::string_view what) {
  return ReadRegular<std::vector<std::byte>>(path, max_bytes, what);
}

Result<std::vector<uint8_t>> ReadRegularFilePrefix(const std::filesystem::path& path, uint64_t length) {
  InputFile f;
  uint64_t size = 0;
  if (auto err = f.Open(path, &size)) return *err;
  const auto shorter = [&] {
    return FileError(ErrorCode::kFormatRejected, path,
                     "is shorter than the " + std::to_string(length) + " bytes expected");
  };
  if (size < length) return shorter();  // refused before allocating
  std::vector<uint8_t> bytes(static_cast<size_t>(length));
  const int64_t got = f.ReadUpTo(reinterpret_cast<char*>(bytes.data()), bytes.size());
  if (got < 0) return FileError(ErrorCode::kFileUnreadable, path, "read error (" + f.reason() + ")");
  if (static_cast<uint64_t>(got) < length) return shorter();
  return bytes;
}

std::optional<Error> WriteWholeFile(const std::filesystem::path& path, std::string_view bytes) {
  CheckedFileWriter out(path);
  out.Write(bytes);
  return out.Close();
}

CheckedFileWriter::CheckedFileWriter(const std::filesystem::path& path)
    : path_(path), file_(OpenForWriting(path, &error_)) {}

CheckedFileWriter::~CheckedFileWriter() {
  if (file_ != nullptr) std::fclose(file_);
}

void CheckedFileWriter::FailWith(const char* step, int errno_value) {
  if (!error_) {
    error_ = FileError(ErrorCode::kFileUnreadable, path_,
                       std::string(step) + " failed (" + (errno_value ? Reason(errno_value) : "unknown error") + ")");
  }
}

bool CheckedFileWriter::Write(std::string_view bytes) {
  if (error_ || file_ == nullptr) return false;
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size()) FailWith("write", errno);
  return !error_;
}

std::optional<Error> CheckedFileWriter::Close() {
  if (file_ != nullptr) {
    errno = 0;
    if (!error_ && std::fflush(file_) != 0) FailWith("write", errno);
    errno = 0;
    if (std::fclose(file_) != 0) FailWith("close", errno);
    file_ = nullptr;
  }
  return error_;
}

std::string OneLine(std::string message) {
  const auto control = [](unsigned char c) { return c < 0x20 || c == 0x7f; };
  if (std::none_of(message.begin(), message.end(), control)) return message;
  std::string line;
  for (const unsigned char c : message) {
    if (!control(c))
      line += static_cast<char>(c);
    else if (c == '\n')
      line += "\\n";
    else if (c == '\r')
      line += "\\r";
    else if (c == '\t')
      line += "\\t";
    else {
      static constexpr char kHex[] = "0123456789abcdef";
      line += {'\\', 'x', kHex[c >> 4], kHex[c & 15]};
    }
  }
  return line;
}

}  // namespace skinspheres::runtime
