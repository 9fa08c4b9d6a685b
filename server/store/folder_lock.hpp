#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "server/base/posix_io.hpp"

namespace soilvol::server {

/// An exclusive advisory lock on a folder (flock(2) on its ".lock" file): one holder at a time
/// among the threads of this process and the processes sharing the folder (replicas on one
/// volume); released when the lock is destroyed or its process ends, so a killed holder never
/// leaves it taken. The file stays, empty.
class FolderLock {
  public:
    /// Waits for the lock. Internal or Unavailable with the errno text when the lock file
    /// cannot be opened or locked.
    static absl::StatusOr<FolderLock> Acquire(const std::string& folder);

  private:
    explicit FolderLock(UniqueFd fd) : fd_(std::move(fd)) {}
    UniqueFd fd_;  ///< closing it releases the lock
};

/// The name of the lock file in a folder; not an entry, not a temp file.
inline constexpr const char* kFolderLockName = ".lock";

}  // namespace soilvol::server
