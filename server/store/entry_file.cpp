#include "server/store/entry_file.hpp"

#include "absl/strings/str_cat.h"
#include "core/common/checksum.hpp"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr std::string_view kMagic = "SOILVOLE";
constexpr std::size_t kVersionAt = 8;
constexpr std::size_t kKindAt = 12;
constexpr std::size_t kSizeAt = 16;

uint32_t KindCode(EntryKind kind) {
    switch (kind) {
        case EntryKind::kCalibration:
            return 1;
        case EntryKind::kContainer:
            return 2;
    }
    return 0;
}

void PutLe(std::string& out, uint64_t value, int bytes) {
    for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((value >> (8 * i)) & 0xff));
}

uint64_t GetLe(std::string_view bytes, std::size_t at, int n) {
    uint64_t value = 0;
    for (int i = n - 1; i >= 0; --i) {
        value = (value << 8) | static_cast<uint8_t>(bytes[at + static_cast<std::size_t>(i)]);
    }
    return value;
}

}  // namespace

std::string_view KindName(EntryKind kind) {
    switch (kind) {
        case EntryKind::kCalibration:
            return "calibration";
        case EntryKind::kContainer:
            return "container";
    }
    return "entry";
}

EntryEnvelope EnvelopeFor(EntryKind kind, std::string_view payload) {
    EntryEnvelope envelope;
    envelope.header.append(kMagic);
    PutLe(envelope.header, kEntrySchemaVersion, 4);
    PutLe(envelope.header, KindCode(kind), 4);
    PutLe(envelope.header, payload.size(), 8);
    PutLe(envelope.trailer, Fnv1a64(payload, Fnv1a64(envelope.header)), 8);
    return envelope;
}

std::string EncodeEntry(EntryKind kind, std::string_view payload) {
    const EntryEnvelope envelope = EnvelopeFor(kind, payload);
    std::string out;
    out.reserve(envelope.header.size() + payload.size() + envelope.trailer.size());
    out.append(envelope.header).append(payload).append(envelope.trailer);
    return out;
}

absl::StatusOr<std::string_view> DecodeEntry(std::string_view bytes, EntryKind expected) {
    // Magic and version first: another version may lay out everything after them differently.
    if (bytes.size() < kEntryHeaderBytes + kEntryTrailerBytes || bytes.substr(0, 8) != kMagic) {
        return absl::DataLossError(
            absl::StrCat("not a soilvol entry (bad magic or only ", bytes.size(), " bytes)"));
    }
    const uint64_t version = GetLe(bytes, kVersionAt, 4);
    if (version != kEntrySchemaVersion) {
        return absl::FailedPreconditionError(absl::StrCat(
            "entry schema version ", version, " (this build reads ", kEntrySchemaVersion, ")"));
    }
    const uint64_t size = GetLe(bytes, kSizeAt, 8);
    const uint64_t available = bytes.size() - kEntryHeaderBytes - kEntryTrailerBytes;
    if (size != available) {
        return absl::DataLossError(absl::StrCat("payload size ", size, " but the file holds ",
                                                available, " (truncated or trailing bytes)"));
    }
    const std::string_view covered = bytes.substr(0, kEntryHeaderBytes + size);
    if (GetLe(bytes, covered.size(), 8) != Fnv1a64(covered)) {
        return absl::DataLossError("checksum mismatch (the file is damaged)");
    }
    const uint64_t kind = GetLe(bytes, kKindAt, 4);
    if (kind != KindCode(expected)) {
        return absl::DataLossError(absl::StrCat("entry kind ", kind, " where a ",
                                                AbslView(KindName(expected)), " (",
                                                KindCode(expected), ") was expected"));
    }
    return bytes.substr(kEntryHeaderBytes, size);
}

}  // namespace soilvol::server
