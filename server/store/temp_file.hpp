#pragma once

#include <chrono>
#include <initializer_list>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "server/base/posix_io.hpp"

namespace soilvol::server {

/// ".<id>.<pid>.<16 hex digits>.tmp": unique across the processes and threads sharing a folder.
std::string TempName(std::string_view id);

/// Whether `name` has TempName's form (with a valid id), i.e. was written by an EntryStore.
bool IsTempName(std::string_view name);

/// A freshly created (O_EXCL), empty temp file.
struct TempFile {
    UniqueFd fd;
    std::string path;
};

/// Creates a temp file for `id` in `folder`. Internal or Unavailable with the errno text.
absl::StatusOr<TempFile> CreateTempFile(const std::string& folder, std::string_view id);

/// Writes `pieces` in order to a new temp file, fsyncs and closes it; its path. On failure the
/// file is removed and the error is Internal or Unavailable with the errno text.
absl::StatusOr<std::string> WriteTempFile(const std::string& folder, std::string_view id,
                                          std::initializer_list<std::string_view> pieces);

/// Removes the temp files in `folder` whose mtime is at least `max_age` old (left by killed
/// writers). Other names, including foreign dotfiles, are left alone.
void RemoveStaleTempFiles(const std::string& folder, std::chrono::seconds max_age);

}  // namespace soilvol::server
