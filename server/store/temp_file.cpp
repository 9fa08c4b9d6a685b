#include "server/store/temp_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/strip.h"
#include "server/base/absl_view.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

constexpr absl::string_view kTempSuffix = ".tmp";
constexpr std::size_t kRandomDigits = 16;
constexpr int kCreateAttempts = 8;

bool IsDigits(absl::string_view s) {
    return !s.empty() &&
           std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

std::string TempName(std::string_view id) {
    thread_local std::mt19937_64 rng(std::random_device{}() ^
                                     (static_cast<uint64_t>(::getpid()) << 32));
    return absl::StrFormat(".%s.%d.%016x%s", AbslView(id), ::getpid(), rng(), kTempSuffix);
}

bool IsTempName(std::string_view whole) {
    absl::string_view name = AbslView(whole);
    if (!absl::ConsumePrefix(&name, ".") || !absl::ConsumeSuffix(&name, kTempSuffix)) {
        return false;
    }
    // Split "<id>.<pid>.<random>" from the right: ids may contain dots.
    const std::size_t random_at = name.rfind('.');
    if (random_at == absl::string_view::npos || random_at == 0 ||
        name.size() - random_at - 1 != kRandomDigits) {
        return false;
    }
    const std::size_t pid_at = name.rfind('.', random_at - 1);
    if (pid_at == absl::string_view::npos) return false;
    return IsDigits(name.substr(pid_at + 1, random_at - pid_at - 1)) &&
           ValidateId(std::string_view(name.data(), pid_at), "").ok();
}

absl::StatusOr<TempFile> CreateTempFile(const std::string& folder, std::string_view id) {
    for (int attempt = 1;; ++attempt) {
        std::string path = absl::StrCat(folder, "/", TempName(id));
        UniqueFd fd = OpenFile(path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd.valid()) return TempFile{std::move(fd), std::move(path)};
        if (errno != EEXIST || attempt == kCreateAttempts) {
            return ErrnoStatus(errno, "cannot create", path);
        }
    }
}

absl::StatusOr<std::string> WriteTempFile(const std::string& folder, std::string_view id,
                                          std::initializer_list<std::string_view> pieces) {
    absl::StatusOr<TempFile> temp = CreateTempFile(folder, id);
    if (!temp.ok()) return temp.status();
    int error = 0;
    for (const std::string_view piece : pieces) {
        error = WriteAll(temp->fd.get(), piece);
        if (error != 0) break;
    }
    if (error == 0 && ::fsync(temp->fd.get()) != 0) error = errno;
    const int close_error = temp->fd.Close();
    if (error == 0) error = close_error;
    if (error == 0) return std::move(temp->path);
    ::unlink(temp->path.c_str());
    return ErrnoStatus(error, "cannot write", temp->path);
}

void RemoveStaleTempFiles(const std::string& folder, std::chrono::seconds max_age) {
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    const int64_t now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(now).count();
    const int64_t max_age_ns = std::chrono::nanoseconds(max_age).count();
    for (const std::string& name : DirectoryNames(folder)) {
        if (!IsTempName(name)) continue;
        const std::string path = absl::StrCat(folder, "/", name);
        struct stat st;
        if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
        const int64_t mtime_ns =
            static_cast<int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec;
        if (now_ns - mtime_ns >= max_age_ns) ::unlink(path.c_str());
    }
}

}  // namespace soilvol::server
