#include "server/store/folder_lock.hpp"

#include <fcntl.h>
#include <sys/file.h>

#include <cerrno>

namespace soilvol::server {

absl::StatusOr<FolderLock> FolderLock::Acquire(const std::string& folder) {
    const std::string path = folder + "/" + kFolderLockName;
    UniqueFd fd = OpenFile(path, O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (!fd.valid()) return ErrnoStatus(errno, "cannot open", path);
    int locked = 0;
    do {
        locked = ::flock(fd.get(), LOCK_EX);
    } while (locked != 0 && errno == EINTR);
    if (locked != 0) return ErrnoStatus(errno, "cannot lock", path);
    return FolderLock(std::move(fd));
}

}  // namespace soilvol::server
