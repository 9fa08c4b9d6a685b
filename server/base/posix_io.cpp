#include "server/base/posix_io.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <system_error>

#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {

namespace {

// What a client may see of a path: its folder and name inside the data directory, a temporary
// file by the id it was for (its name also holds the server's pid and a random tag).
std::string DisplayPath(std::string_view path) {
    const std::size_t name_at = path.rfind('/');
    std::string_view name = name_at == std::string_view::npos ? path : path.substr(name_at + 1);
    std::string_view folder;
    if (name_at != std::string_view::npos && name_at > 0) {
        const std::size_t folder_at = path.rfind('/', name_at - 1);
        folder = path.substr(folder_at == std::string_view::npos ? 0 : folder_at + 1,
                             name_at - (folder_at == std::string_view::npos ? 0 : folder_at + 1));
    }
    std::string shown(name);
    if (name.size() > 4 && name.front() == '.' && name.substr(name.size() - 4) == ".tmp") {
        const std::size_t id_end = name.find('.', 1);
        shown = absl::StrCat("a temporary file for ", AbslView(name.substr(1, id_end - 1)));
    }
    return folder.empty() ? shown : absl::StrCat(AbslView(folder), "/", shown);
}

}  // namespace

absl::Status ErrnoStatus(int error_number, std::string_view what, std::string_view path) {
    std::string message = absl::StrCat("data directory: ", AbslView(what), " ", DisplayPath(path),
                                       ": ", std::generic_category().message(error_number));
    switch (error_number) {
        case ENOSPC:
        case EDQUOT:
        case EROFS:
        case EIO:
        case EMFILE:
        case ENFILE:
        case ENOMEM:
        case EAGAIN:
        case EBUSY:
        case ESTALE:
            return absl::UnavailableError(message);
        default:
            return absl::InternalError(message);
    }
}

UniqueFd& UniqueFd::operator=(UniqueFd&& other) noexcept {
    if (this != &other) {
        Close();
        fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
}

UniqueFd::~UniqueFd() { Close(); }

int UniqueFd::Close() {
    if (fd_ < 0) return 0;
    // Linux frees the descriptor even when close(2) fails, so it is never retried.
    const int result = ::close(std::exchange(fd_, -1));
    return (result == 0 || errno == EINTR) ? 0 : errno;
}

UniqueFd OpenFile(const std::string& path, int flags, mode_t mode) {
    int fd;
    do {
        fd = ::open(path.c_str(), flags, mode);
    } while (fd < 0 && errno == EINTR);
    return UniqueFd(fd);
}

int WriteAll(int fd, std::string_view bytes) {
    while (!bytes.empty()) {
        const ssize_t n = ::write(fd, bytes.data(), bytes.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        if (n == 0) return EIO;
        bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    return 0;
}

int ReadAll(int fd, std::string& out) {
    std::size_t done = 0;
    while (done < out.size()) {
        const ssize_t n = ::read(fd, out.data() + done, out.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        if (n == 0) break;
        done += static_cast<std::size_t>(n);
    }
    out.resize(done);
    return 0;
}

absl::Status SyncDirectory(const std::string& path) {
    UniqueFd dir = OpenFile(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (!dir.valid()) return ErrnoStatus(errno, "cannot open", path);
    if (::fsync(dir.get()) != 0) return ErrnoStatus(errno, "cannot fsync", path);
    return absl::OkStatus();
}

std::vector<std::string> DirectoryNames(const std::string& path) {
    std::vector<std::string> names;
    DIR* dir = ::opendir(path.c_str());
    if (dir == nullptr) return names;
    while (const dirent* entry = ::readdir(dir)) {
        const std::string_view name = entry->d_name;
        if (name != "." && name != "..") names.emplace_back(name);
    }
    ::closedir(dir);
    return names;
}

FileStamp StampOf(const struct stat& st) {
    return FileStamp{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino),
                     static_cast<uint64_t>(st.st_size),
                     static_cast<int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec};
}

FileStamp StampOfPath(const std::string& path) {
    struct stat st {};
    if (path.empty() || ::stat(path.c_str(), &st) != 0) return {};
    return StampOf(st);
}

}  // namespace soilvol::server
