#include "server/store/entry_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "core/common/status_macros.hpp"
#include "server/base/absl_view.hpp"
#include "server/base/posix_io.hpp"
#include "server/store/entry_id.hpp"
#include "server/store/folder_lock.hpp"
#include "server/store/temp_file.hpp"

namespace soilvol::server {
namespace {

constexpr absl::string_view kEntrySuffix = ".entry";
constexpr std::string_view kProbeId = "probe";

std::string Label(EntryKind kind, std::string_view id) {
    return absl::StrCat(AbslView(KindName(kind)), " '", AbslView(id), "'");
}

std::string IdField(EntryKind kind) { return absl::StrCat(AbslView(KindName(kind)), " id"); }

absl::Status PrepareFolder(const std::string& path) {
    if (::mkdir(path.c_str(), 0755) != 0 && errno != EEXIST) {
        return absl::FailedPreconditionError(ErrnoStatus(errno, "cannot create", path).message());
    }
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) {
        return absl::FailedPreconditionError(ErrnoStatus(errno, "cannot stat", path).message());
    }
    if (!S_ISDIR(st.st_mode)) {
        return absl::FailedPreconditionError(absl::StrCat(path, " is not a directory"));
    }
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<EntryStore>> EntryStore::Open(const std::filesystem::path& root,
                                                             const EntryStoreConfig& config) {
    std::error_code ec;
    std::filesystem::create_directories(root, ec);
    if (ec) {
        return absl::FailedPreconditionError(
            absl::StrCat("cannot create data directory ", root.string(), ": ", ec.message()));
    }
    SOILVOL_RETURN_IF_ERROR(PrepareFolder(root.string()));
    std::unique_ptr<EntryStore> store(new EntryStore(root));
    for (const EntryKind kind : {EntryKind::kCalibration, EntryKind::kContainer}) {
        SOILVOL_RETURN_IF_ERROR(PrepareFolder(store->Folder(kind)));
    }
    if (const absl::Status writable = store->CheckWritable(); !writable.ok()) {
        return absl::FailedPreconditionError(writable.message());
    }
    for (const EntryKind kind : {EntryKind::kCalibration, EntryKind::kContainer}) {
        RemoveStaleTempFiles(store->Folder(kind), config.stale_temp_age);
    }
    return store;
}

absl::Status EntryStore::Put(EntryKind kind, std::string_view id, std::string_view payload,
                             bool overwrite) {
    if (overwrite) return Publish(kind, id, payload, nullptr);
    const std::string label = Label(kind, id);
    // A cheap early answer before the write; the check under the lock decides races.
    if (Stat(kind, id).ok()) return absl::AlreadyExistsError(label + " already exists");
    return Publish(kind, id, payload, [&label](const absl::StatusOr<StoredEntry>& current) {
        return absl::IsNotFound(current.status())
                   ? absl::OkStatus()
                   : absl::AlreadyExistsError(label + " already exists");
    });
}

absl::Status EntryStore::PutIf(EntryKind kind, std::string_view id, std::string_view payload,
                               const Precondition& expect) {
    return Publish(kind, id, payload, expect);
}

absl::Status EntryStore::Publish(EntryKind kind, std::string_view id, std::string_view payload,
                                 const Precondition& expect) {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, IdField(kind)));
    if (payload.size() > kMaxEntryPayloadBytes) {
        return absl::InvalidArgumentError(absl::StrCat(Label(kind, id), " is ", payload.size(),
                                                       " bytes, more than the limit of ",
                                                       kMaxEntryPayloadBytes));
    }
    const std::string target = EntryPath(kind, id);
    // Write and fsync a temp file next to the target (outside the lock: it may be large), then
    // check and publish under the lock: rename(2) replaces atomically.
    const EntryEnvelope envelope = EnvelopeFor(kind, payload);
    SOILVOL_ASSIGN_OR_RETURN(
        const std::string temp,
        WriteTempFile(Folder(kind), id, {envelope.header, payload, envelope.trailer}));
    absl::Status published = [&]() -> absl::Status {
        SOILVOL_ASSIGN_OR_RETURN(const FolderLock lock, FolderLock::Acquire(Folder(kind)));
        if (expect) SOILVOL_RETURN_IF_ERROR(expect(Get(kind, id)));
        if (::rename(temp.c_str(), target.c_str()) != 0) {
            return ErrnoStatus(errno, "cannot publish", target);
        }
        return SyncDirectory(Folder(kind));
    }();
    if (!published.ok()) ::unlink(temp.c_str());
    return published;
}

absl::StatusOr<StoredEntry> EntryStore::Get(EntryKind kind, std::string_view id) const {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, IdField(kind)));
    const std::string path = EntryPath(kind, id);
    // O_NONBLOCK: a FIFO planted under an entry's name must not hang the reader.
    const UniqueFd fd = OpenFile(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (!fd.valid() && errno == ENOENT) return absl::NotFoundError(Label(kind, id) + " not found");
    if (!fd.valid()) return ErrnoStatus(errno, "cannot open", path);
    struct stat st;
    if (::fstat(fd.get(), &st) != 0) return ErrnoStatus(errno, "cannot stat", path);
    const std::string label = Label(kind, id);
    if (!S_ISREG(st.st_mode)) return absl::DataLossError(label + ": not a regular file");
    const uint64_t limit = kEntryHeaderBytes + kMaxEntryPayloadBytes + kEntryTrailerBytes;
    if (static_cast<uint64_t>(st.st_size) > limit) {
        return absl::DataLossError(absl::StrCat(label, ": file is ", st.st_size,
                                                " bytes, more than the limit of ", limit));
    }
    std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
    if (const int error = ReadAll(fd.get(), bytes); error != 0) {
        return ErrnoStatus(error, "cannot read", path);
    }
    const absl::StatusOr<std::string_view> payload = DecodeEntry(bytes, kind);
    if (!payload.ok()) {
        return absl::Status(payload.status().code(),
                            absl::StrCat(label, ": ", payload.status().message()));
    }
    // Strip the envelope in place rather than copying a payload of up to 1 GiB.
    bytes.resize(kEntryHeaderBytes + payload->size());
    bytes.erase(0, kEntryHeaderBytes);
    return StoredEntry{std::string(id), std::move(bytes), StampOf(st)};
}

absl::StatusOr<FileStamp> EntryStore::Stat(EntryKind kind, std::string_view id) const {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, IdField(kind)));
    const std::string path = EntryPath(kind, id);
    struct stat st;
    if (::stat(path.c_str(), &st) == 0) return StampOf(st);
    if (errno == ENOENT) return absl::NotFoundError(Label(kind, id) + " not found");
    return ErrnoStatus(errno, "cannot stat", path);
}

absl::Status EntryStore::Delete(EntryKind kind, std::string_view id) {
    return DeleteIf(kind, id, nullptr);
}

absl::Status EntryStore::DeleteIf(EntryKind kind, std::string_view id, const Precondition& expect) {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, IdField(kind)));
    const std::string path = EntryPath(kind, id);
    SOILVOL_ASSIGN_OR_RETURN(const FolderLock lock, FolderLock::Acquire(Folder(kind)));
    if (expect) SOILVOL_RETURN_IF_ERROR(expect(Get(kind, id)));
    if (::unlink(path.c_str()) != 0) {
        if (errno == ENOENT) return absl::NotFoundError(Label(kind, id) + " not found");
        return ErrnoStatus(errno, "cannot delete", path);
    }
    return SyncDirectory(Folder(kind));
}

std::vector<std::string> EntryStore::List(EntryKind kind) const {
    std::vector<std::string> ids;
    for (const std::string& name : DirectoryNames(Folder(kind))) {
        absl::string_view id = name;
        if (absl::ConsumeSuffix(&id, kEntrySuffix) &&
            ValidateId(std::string_view(id.data(), id.size()), "").ok()) {
            ids.emplace_back(id);
        }
    }
    std::sort(ids.begin(), ids.end());
    return ids;
}

absl::Status EntryStore::CheckWritable() const {
    for (const EntryKind kind : {EntryKind::kCalibration, EntryKind::kContainer}) {
        SOILVOL_ASSIGN_OR_RETURN(TempFile probe, CreateTempFile(Folder(kind), kProbeId));
        const int close_error = probe.fd.Close();
        if (::unlink(probe.path.c_str()) != 0)
            return ErrnoStatus(errno, "cannot remove", probe.path);
        if (close_error != 0) return ErrnoStatus(close_error, "cannot close", probe.path);
    }
    return absl::OkStatus();
}

std::string EntryStore::Folder(EntryKind kind) const {
    switch (kind) {
        case EntryKind::kCalibration:
            return (root_ / "calibrations").string();
        case EntryKind::kContainer:
            return (root_ / "containers").string();
    }
    return root_.string();
}

std::string EntryStore::EntryPath(EntryKind kind, std::string_view id) const {
    return absl::StrCat(Folder(kind), "/", AbslView(id), kEntrySuffix);
}

}  // namespace soilvol::server
