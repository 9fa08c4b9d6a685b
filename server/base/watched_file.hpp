#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/base/posix_io.hpp"

namespace soilvol::server {

/// Files that are read again when they change: Changed() says so at most once per `period`.
class WatchedFiles {
  public:
    explicit WatchedFiles(std::vector<std::string> paths,
                          std::chrono::milliseconds period = std::chrono::seconds(1));
    /// True when a stamp differs from the last Mark(), looked at no more than once per period.
    /// Not thread-safe: callers hold their own lock.
    bool Changed();
    /// Records the files' stamps as the ones now loaded.
    void Mark();

  private:
    std::vector<FileStamp> Stamps() const;

    std::vector<std::string> paths_;
    std::chrono::milliseconds period_;
    std::vector<FileStamp> stamps_;
    std::chrono::steady_clock::time_point checked_;
};

/// The contents of a regular file of at most `max_bytes`; InvalidArgument naming `flag` when
/// it is missing, unreadable, not a regular file or larger.
absl::StatusOr<std::string> ReadSmallFile(const std::string& path, std::size_t max_bytes,
                                          const std::string& flag);

}  // namespace soilvol::server
