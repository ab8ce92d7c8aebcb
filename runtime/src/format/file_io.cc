#include "skinspheres/runtime/format/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

namespace skinspheres::runtime {
namespace {

Error FileError(ErrorCode code, const std::filesystem::path& path, const std::string& problem) {
  return MakeError(code, path.string() + ": " + problem);
}

std::string Reason(int errno_value) { return std::strerror(errno_value); }

// Closes the descriptor on every path out of ReadRegularFile.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

const char* NotRegular(mode_t mode) {
  if (S_ISDIR(mode)) return "is a directory, not a file";
  if (S_ISFIFO(mode)) return "is a FIFO (named pipe), not a regular file";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "is a device, not a regular file";
  if (S_ISSOCK(mode)) return "is a socket, not a regular file";
  return "is not a regular file";
}

// Opens `path` for reading when it is a regular file (non-blocking open, so a FIFO is refused
// at once); `size` gets its size.
std::optional<Error> OpenRegular(const std::filesystem::path& path, Fd* f, uint64_t* size) {
  if (path.empty()) return MakeError(ErrorCode::kInvalidArgument, "empty path: no file named");
  do {
    f->fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  } while (f->fd < 0 && errno == EINTR);
  if (f->fd < 0) {
    const int e = errno;
    if (e == ENOENT || e == ENOTDIR) return FileError(ErrorCode::kFileNotFound, path, "file not found");
    if (e == EACCES || e == EPERM) return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (permission denied)");
    return FileError(ErrorCode::kFileUnreadable, path, "cannot be opened for reading (" + Reason(e) + ")");
  }
  struct stat st {};
  if (::fstat(f->fd, &st) != 0) return FileError(ErrorCode::kFileUnreadable, path, "cannot be read (" + Reason(errno) + ")");
  if (!S_ISREG(st.st_mode)) return FileError(ErrorCode::kFileUnreadable, path, NotRegular(st.st_mode));
  *size = static_cast<uint64_t>(std::max<off_t>(st.st_size, 0));
  // A regular file never blocks; back to blocking reads so a slow disk is waited on, not an error.
  const int flags = ::fcntl(f->fd, F_GETFL);
  if (flags >= 0) ::fcntl(f->fd, F_SETFL, flags & ~O_NONBLOCK);
  return std::nullopt;
}

// read() until `out` is full or the file ends; the number of bytes read, or -1 (errno set).
int64_t ReadUpTo(int fd, char* out, size_t n) {
  size_t have = 0;
  while (have < n) {
    const ssize_t got = ::read(fd, out + have, n - have);
    if (got < 0) {
      if (errno == EINTR) continue;
      return -1;
    }
    if (got == 0) break;
    have += static_cast<size_t>(got);
  }
  return static_cast<int64_t>(have);
}

// ReadRegularFile into any contiguous byte container with resize() (std::string, a byte vector).
template <typename Bytes>
Result<Bytes> ReadRegular(const std::filesystem::path& path, uint64_t max_bytes, std::string_view what) {
  Fd f;
  uint64_t size = 0;
  if (auto err = OpenRegular(path, &f, &size)) return *err;
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
    const int64_t got = ReadUpTo(f.fd, reinterpret_cast<char*>(bytes.data()) + have, bytes.size() - have);
    if (got < 0) return FileError(ErrorCode::kFileUnreadable, path, "read error (" + Reason(errno) + ")");
    have += static_cast<size_t>(got);
    if (have < bytes.size()) break;  // the end of the file
    if (have > max_bytes) return too_large(max_bytes, true);
    bytes.resize(have + std::min<uint64_t>(std::max<size_t>(have, 64 * 1024), max_bytes + 1 - have));
  }
  bytes.resize(have);
  return bytes;
}

}  // namespace

Result<std::string> ReadRegularFile(const std::filesystem::path& path, uint64_t max_bytes, std::string_view what) {
  return ReadRegular<std::string>(path, max_bytes, what);
}

Result<std::vector<std::byte>> ReadRegularFileBytes(const std::filesystem::path& path, uint64_t max_bytes,
                                                    std::string_view what) {
  return ReadRegular<std::vector<std::byte>>(path, max_bytes, what);
}

Result<std::vector<uint8_t>> ReadRegularFilePrefix(const std::filesystem::path& path, uint64_t length) {
  Fd f;
  uint64_t size = 0;
  if (auto err = OpenRegular(path, &f, &size)) return *err;
  const auto shorter = [&] {
    return FileError(ErrorCode::kFormatRejected, path, "is shorter than the " + std::to_string(length) + " bytes expected");
  };
  if (size < length) return shorter();  // refused before allocating
  std::vector<uint8_t> bytes(static_cast<size_t>(length));
  const int64_t got = ReadUpTo(f.fd, reinterpret_cast<char*>(bytes.data()), bytes.size());
  if (got < 0) return FileError(ErrorCode::kFileUnreadable, path, "read error (" + Reason(errno) + ")");
  if (static_cast<uint64_t>(got) < length) return shorter();
  return bytes;
}

std::optional<Error> WriteWholeFile(const std::filesystem::path& path, std::string_view bytes) {
  CheckedFileWriter out(path);
  out.Write(bytes);
  return out.Close();
}

CheckedFileWriter::CheckedFileWriter(const std::filesystem::path& path) : path_(path) {
  // Non-blocking open: a FIFO nobody reads fails at once (ENXIO) instead of waiting for a reader
  // forever. Once open, writes block as usual (a pipe with a reader, a slow disk).
  int fd = -1;
  do {
    fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NONBLOCK | O_CLOEXEC | O_NOCTTY, 0666);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int e = errno;
    struct stat st {};
    const bool fifo = e == ENXIO && ::stat(path.c_str(), &st) == 0 && S_ISFIFO(st.st_mode);
    error_ = FileError(ErrorCode::kFileUnreadable, path_,
                       fifo ? "is a FIFO (named pipe) nobody reads: cannot write to it"
                            : "cannot open for writing (" + Reason(e) + ")");
    return;
  }
  const int flags = ::fcntl(fd, F_GETFL);
  if (flags >= 0) ::fcntl(fd, F_SETFL, flags & ~O_NONBLOCK);
  file_ = ::fdopen(fd, "wb");
  if (file_ == nullptr) {
    error_ = FileError(ErrorCode::kFileUnreadable, path_, "cannot open for writing (" + Reason(errno) + ")");
    ::close(fd);
  }
}

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
    if (!control(c)) line += static_cast<char>(c);
    else if (c == '\n') line += "\\n";
    else if (c == '\r') line += "\\r";
    else if (c == '\t') line += "\\t";
    else {
      static constexpr char kHex[] = "0123456789abcdef";
      line += {'\\', 'x', kHex[c >> 4], kHex[c & 15]};
    }
  }
  return line;
}

JsonShape ScanJson(std::string_view text) {
  JsonShape shape;
  size_t depth = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;  // the escaped character cannot end the string
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      shape.depth = std::max(shape.depth, ++depth);
      ++shape.values;
    } else if (c == ',') {
      ++shape.values;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return shape;
}

}  // namespace skinspheres::runtime
