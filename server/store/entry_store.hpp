#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/base/posix_io.hpp"
#include "server/store/entry_file.hpp"

namespace soilvol::server {

/// One entry as read: payload and the stamp of the file it came from.
struct StoredEntry {
    std::string id;
    std::string payload;
    FileStamp stamp;
};

struct EntryStoreConfig {
    /// Temp files older than this are left by killed writers and removed by Open.
    std::chrono::seconds stale_temp_age = std::chrono::hours(1);
};

/// Container models and calibrations as opaque payloads in a data directory, one file per
/// entry: <root>/{calibrations,containers}/<id>.entry. Stateless (several processes may share
/// the root) and thread-safe. Writes are atomic: a reader, or a writer killed at any moment,
/// leaves either no entry or a complete one.
class EntryStore {
  public:
    /// Creates <root> and its kind folders when missing and removes stale temp files.
    /// FailedPrecondition (naming the path and the errno text) when root cannot be created or
    /// is not a writable directory.
    static absl::StatusOr<std::unique_ptr<EntryStore>> Open(const std::filesystem::path& root,
                                                            const EntryStoreConfig& config = {});

    /// Publishes `payload` (at most kMaxEntryPayloadBytes) under `id`. InvalidArgument for a bad
    /// id or size; AlreadyExists when the id exists and !overwrite (exactly one of several
    /// racing creators wins); Internal or Unavailable with the errno text on I/O failure.
    absl::Status Put(EntryKind kind, std::string_view id, std::string_view payload, bool overwrite);

    /// What a conditional write or delete requires of the entry published now (NotFound when
    /// there is none, DataLoss when it is damaged): OK to go on, else the call's error.
    using Precondition = std::function<absl::Status(const absl::StatusOr<StoredEntry>& current)>;

    /// A compare-and-swap: publishes `payload` under `id` if `expect` accepts the entry published
    /// now, with no other write or delete of that kind in between, in this process or another
    /// sharing the root (FolderLock). Of several writers expecting the same entry exactly one
    /// wins; the others get what `expect` says of the winner's. Errors as Put's, or expect's.
    absl::Status PutIf(EntryKind kind, std::string_view id, std::string_view payload,
                       const Precondition& expect);

    /// The entry's payload, with the stamp of the very file read. NotFound when absent;
    /// DataLoss for a damaged, oversized or non-regular file and FailedPrecondition for another
    /// schema version, the message prefixed with the kind and id.
    absl::StatusOr<StoredEntry> Get(EntryKind kind, std::string_view id) const;

    /// The entry file's stamp without reading it. NotFound when absent.
    absl::StatusOr<FileStamp> Stat(EntryKind kind, std::string_view id) const;

    /// Removes the entry. NotFound when absent.
    absl::Status Delete(EntryKind kind, std::string_view id);

    /// Removes the entry if `expect` accepts it, atomically as PutIf. NotFound when absent.
    absl::Status DeleteIf(EntryKind kind, std::string_view id, const Precondition& expect);

    /// Sorted ids of the published entries (damaged ones included); ignores temp files,
    /// dotfiles and names that are not valid ids. Empty when the folder cannot be read.
    std::vector<std::string> List(EntryKind kind) const;

    /// For readiness probes: creates and removes a temp file in each kind folder.
    absl::Status CheckWritable() const;

    const std::filesystem::path& root() const { return root_; }

  private:
    explicit EntryStore(std::filesystem::path root) : root_(std::move(root)) {}
    std::string Folder(EntryKind kind) const;
    std::string EntryPath(EntryKind kind, std::string_view id) const;
    /// Writes `payload` to a temp file, then under the kind's FolderLock asks `expect` (when
    /// set) about the entry published now and renames the temp file over it.
    absl::Status Publish(EntryKind kind, std::string_view id, std::string_view payload,
                         const Precondition& expect);

    std::filesystem::path root_;
};

}  // namespace soilvol::server
