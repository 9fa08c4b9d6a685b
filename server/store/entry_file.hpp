#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// What an entry holds; stored in the envelope so a file cannot be read as the other kind.
enum class EntryKind { kCalibration, kContainer };

/// "calibration" or "container", for messages.
std::string_view KindName(EntryKind kind);

/// Version of the envelope layout; other versions are refused on decoding.
inline constexpr uint32_t kEntrySchemaVersion = 1;
/// Largest accepted payload [bytes] (1 GiB).
inline constexpr uint64_t kMaxEntryPayloadBytes = uint64_t{1} << 30;
/// Envelope bytes before the payload: magic "SOILVOLE", u32 version, u32 kind, u64 size.
inline constexpr std::size_t kEntryHeaderBytes = 8 + 4 + 4 + 8;
/// Envelope bytes after the payload: u64 FNV-1a of everything before it.
inline constexpr std::size_t kEntryTrailerBytes = 8;

/// The bytes around a payload, so a writer can send the payload without copying it.
struct EntryEnvelope {
    std::string header;   ///< kEntryHeaderBytes
    std::string trailer;  ///< kEntryTrailerBytes
};

/// Header and trailer (checksum over header and payload) for `payload`, little-endian.
EntryEnvelope EnvelopeFor(EntryKind kind, std::string_view payload);

/// The whole file: header + payload + trailer.
std::string EncodeEntry(EntryKind kind, std::string_view payload);

/// The payload inside EncodeEntry's bytes, as a view into `bytes`. DataLoss for a bad magic,
/// size or checksum, truncation or trailing bytes, an unknown kind or another kind than
/// `expected` (the message says which); FailedPrecondition for another schema version.
absl::StatusOr<std::string_view> DecodeEntry(std::string_view bytes, EntryKind expected);

}  // namespace soilvol::server
