#include "server/base/watched_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "server/base/posix_io.hpp"

namespace soilvol::server {

WatchedFiles::WatchedFiles(std::vector<std::string> paths, std::chrono::milliseconds period)
    : paths_(std::move(paths)), period_(period), checked_(std::chrono::steady_clock::now()) {
    Mark();
}

std::vector<FileStamp> WatchedFiles::Stamps() const {
    std::vector<FileStamp> stamps;
    stamps.reserve(paths_.size());
    for (const std::string& path : paths_) stamps.push_back(StampOfPath(path));
    return stamps;
}

bool WatchedFiles::Changed() {
    const auto now = std::chrono::steady_clock::now();
    if (now - checked_ < period_) return false;
    checked_ = now;
    return Stamps() != stamps_;
}

void WatchedFiles::Mark() { stamps_ = Stamps(); }

absl::StatusOr<std::string> ReadSmallFile(const std::string& path, std::size_t max_bytes,
                                          const std::string& flag) {
    // O_NONBLOCK: a FIFO in the file's place must not hang the server (it is refused below).
    UniqueFd fd = OpenFile(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (!fd.valid()) {
        return absl::InvalidArgumentError(
            absl::StrCat("--", flag, ": cannot open ", path, ": ", std::strerror(errno)));
    }
    struct stat info {};
    if (::fstat(fd.get(), &info) != 0 || !S_ISREG(info.st_mode)) {
        return absl::InvalidArgumentError(
            absl::StrCat("--", flag, ": ", path, " is not a regular file"));
    }
    if (static_cast<std::uint64_t>(info.st_size) > max_bytes) {
        return absl::InvalidArgumentError(
            absl::StrCat("--", flag, ": ", path, " is larger than ", max_bytes, " bytes"));
    }
    std::string text(max_bytes + 1, '\0');
    if (const int error = ReadAll(fd.get(), text); error != 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("--", flag, ": cannot read ", path, ": ", std::strerror(error)));
    }
    if (text.size() > max_bytes) {
        return absl::InvalidArgumentError(
            absl::StrCat("--", flag, ": ", path, " is larger than ", max_bytes, " bytes"));
    }
    return text;
}

}  // namespace soilvol::server
