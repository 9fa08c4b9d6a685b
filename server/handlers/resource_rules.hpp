#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// The Google AIP rules for soilvol's resources, free of any message type.

/// One page of a sorted id list (AIP-158).
struct Page {
    std::vector<std::string> ids;  ///< this page's ids, in order
    std::string next_page_token;   ///< "" on the last page
};

inline constexpr int kDefaultPageSize = 100;
inline constexpr int kMaxPageSize = 1000;

/// The page of `sorted_ids` after `page_token` (opaque: web-safe base64 of the last id
/// served): `page_size` 0 means kDefaultPageSize, more than kMaxPageSize means kMaxPageSize.
/// InvalidArgument naming page_size (negative) or page_token (not one this server made).
/// Entries created or deleted between pages neither repeat nor shift the others.
absl::StatusOr<Page> PageOf(const std::vector<std::string>& sorted_ids, int page_size,
                            std::string_view page_token);

/// A page size as AIP-158 has it: 0 means kDefaultPageSize, more than kMaxPageSize means
/// kMaxPageSize; InvalidArgument naming page_size when negative.
absl::StatusOr<int> PageSizeOf(int page_size);

/// Pages of estimate records, newest first: the token names the last id served.
std::string RecordPageToken(std::int64_t last_id);
/// nullopt for "" (the first page); InvalidArgument naming page_token for one not made here.
absl::StatusOr<std::optional<std::int64_t>> ParseRecordPageToken(std::string_view page_token);
/// An estimate id: a positive decimal integer; InvalidArgument naming `field` otherwise.
absl::StatusOr<std::int64_t> ParseRecordId(std::string_view text, std::string_view field);
/// Where a watch resumes: an id as ParseRecordId, or "0" for before the first (every row kept).
absl::StatusOr<std::int64_t> ParseResumeId(std::string_view text, std::string_view field);

/// AIP-155: "" (none) or 1-128 characters of [A-Za-z0-9._:-] (a UUID fits).
absl::Status ValidateRequestId(std::string_view request_id, std::string_view field);

/// An id the server picks for a create without one: "<prefix>-<12 hex>", random, or derived
/// from `request_id` when there is one so that a retry lands on the same id.
std::string ServerChosenId(std::string_view prefix, std::string_view request_id);

/// A resource's display name: at most 200 bytes, no control characters.
absl::Status ValidateDisplayName(std::string_view name, std::string_view field);

inline constexpr int kMaxLabels = 64;

/// One label, as Kubernetes has them: key 1-63 of [a-z0-9_.-] starting with a letter, value
/// 0-63 of [A-Za-z0-9_.-]. InvalidArgument naming `field` and the key.
absl::Status ValidateLabel(std::string_view key, std::string_view value, std::string_view field);

/// A fresh etag for a new write (AIP-154): 16 random hex digits.
std::string NewEtag();

/// The etag of an entry written before etags existed, from its stored bytes.
std::string EtagOf(std::string_view payload);

/// OK when `expected` is empty or equals `current`; otherwise ABORTED, reason ETAG_MISMATCH,
/// naming the field "etag".
absl::Status CheckEtag(std::string_view expected, std::string_view current, std::string_view what);

}  // namespace soilvol::server
