#pragma once
// Shared by the fuzz targets: an in-memory file for readers that take a path, and property checks that
// abort (so libFuzzer saves the input as a crash) when a reader breaks its documented contract.
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace exoid::fuzz {

/// Aborts with a message naming the broken property; libFuzzer records the input.
#define EXOID_FUZZ_CHECK(cond, what)                                                    \
  do {                                                                                  \
    if (!(cond)) {                                                                      \
      std::fprintf(stderr, "fuzz property violated: %s (%s:%d)\n", what, __FILE__, __LINE__); \
      std::abort();                                                                     \
    }                                                                                   \
  } while (0)

/// Every reader reports a failure as one non-empty line (docs/conventions.md): aborts otherwise, showing it.
inline void checkOneLine(const std::string& message, const char* what) {
  if (!message.empty() && message.find('\n') == std::string::npos) return;
  std::fprintf(stderr, "fuzz property violated: %s; the message was:\n[%s]\n", what, message.c_str());
  std::abort();
}

/// An anonymous in-memory file (memfd), reachable by path as /proc/self/fd/N: the input reaches a
/// path-taking reader without touching the disk. One per process, rewritten for every input.
class MemFile {
 public:
  MemFile() : fd_(memfd_create("exoid_fuzz", 0)) {
    if (fd_ < 0) {
      std::perror("memfd_create");
      std::abort();
    }
    path_ = "/proc/self/fd/" + std::to_string(fd_);
  }
  ~MemFile() { close(fd_); }
  MemFile(const MemFile&) = delete;
  MemFile& operator=(const MemFile&) = delete;

  /// Replaces the content with `size` bytes; returns the path.
  const std::string& write(const uint8_t* data, size_t size) {
    if (ftruncate(fd_, 0) != 0) std::abort();
    size_t done = 0;
    while (done < size) {
      const ssize_t n = pwrite(fd_, data + done, size - done, static_cast<off_t>(done));
      if (n <= 0) std::abort();
      done += static_cast<size_t>(n);
    }
    return path_;
  }

 private:
  int fd_;
  std::string path_;
};

}  // namespace exoid::fuzz
