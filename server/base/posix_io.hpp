#pragma once

#include <sys/stat.h>
#include <sys/types.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"

namespace soilvol::server {

/// Identity and version of a file, from one stat; equal stamps mean unchanged content.
/// An overwrite publishes a new file, so the inode changes even within one mtime tick (only an
/// equal-sized rewrite that reuses a just-freed inode within one tick would go unnoticed).
struct FileStamp {
    uint64_t device = 0;
    uint64_t inode = 0;
    uint64_t size = 0;     ///< [bytes] of the whole file
    int64_t mtime_ns = 0;  ///< [ns] since the epoch

    bool operator==(const FileStamp& o) const {
        return device == o.device && inode == o.inode && size == o.size && mtime_ns == o.mtime_ns;
    }
    bool operator!=(const FileStamp& o) const { return !(*this == o); }
};

/// The stamp of `st`.
FileStamp StampOf(const struct stat& st);
/// The stamp of the file `path` leads to (symbolic links followed); all zero when it cannot be
/// read.
FileStamp StampOfPath(const std::string& path);

/// Unavailable for conditions an operator can fix or that pass (full disk, read-only file
/// system, I/O error, no descriptors), Internal otherwise; the message is
/// "<what> <path>: <errno text>". Takes no allocating arguments, so `errno` can be passed as is.
absl::Status ErrnoStatus(int error_number, std::string_view what, std::string_view path);

/// Owns a file descriptor; closes it (ignoring errors) unless Close() was called.
class UniqueFd {
  public:
    explicit UniqueFd(int fd = -1) : fd_(fd) {}
    UniqueFd(UniqueFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    UniqueFd& operator=(UniqueFd&& other) noexcept;
    UniqueFd(const UniqueFd&) = delete;
    UniqueFd& operator=(const UniqueFd&) = delete;
    ~UniqueFd();

    int get() const { return fd_; }
    bool valid() const { return fd_ >= 0; }
    /// Closes now; the errno of a failed close(2), else 0.
    int Close();

  private:
    int fd_;
};

/// open(2), retried on EINTR. Invalid (with errno set) on failure.
UniqueFd OpenFile(const std::string& path, int flags, mode_t mode = 0);

/// write(2) until all of `bytes` is written, retried on EINTR; 0 or the errno.
int WriteAll(int fd, std::string_view bytes);

/// read(2) into `out` until it is full or the file ends, retried on EINTR; `out` is shrunk to
/// what was read. 0 or the errno.
int ReadAll(int fd, std::string& out);

/// fsync(2) of a directory, so that names published or removed in it survive a crash.
absl::Status SyncDirectory(const std::string& path);

/// Names in a directory except "." and ".."; empty when it cannot be read.
std::vector<std::string> DirectoryNames(const std::string& path);

}  // namespace soilvol::server
