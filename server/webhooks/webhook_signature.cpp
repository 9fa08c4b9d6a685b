#include "server/webhooks/webhook_signature.hpp"

#include <openssl/core_names.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/params.h>

#include <array>
#include <optional>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr std::size_t kMacBytes = 32;            // SHA-256
constexpr std::size_t kMaxHeaderLength = 4096;   // a few signatures during a secret's rotation
constexpr std::size_t kMaxTimestampDigits = 18;  // below 2^63
using Mac = std::array<unsigned char, kMacBytes>;

// HMAC-SHA256 of "<unix_seconds>.<body>" under `secret`; nullopt when OpenSSL fails.
std::optional<Mac> ComputeMac(std::string_view secret, std::int64_t unix_seconds,
                              std::string_view body) {
    static const unsigned char kEmptyKey = 0;  // EVP_MAC_init takes a null key as "keep the key"
    const std::string prefix = absl::StrCat(unix_seconds, ".");
    const auto* key =
        secret.empty() ? &kEmptyKey : reinterpret_cast<const unsigned char*>(secret.data());
    char digest[] = "SHA256";
    const OSSL_PARAM params[] = {OSSL_PARAM_construct_utf8_string(OSSL_MAC_PARAM_DIGEST, digest, 0),
                                 OSSL_PARAM_construct_end()};
    EVP_MAC* hmac = EVP_MAC_fetch(nullptr, "HMAC", nullptr);
    EVP_MAC_CTX* context = hmac != nullptr ? EVP_MAC_CTX_new(hmac) : nullptr;
    Mac mac{};
    std::size_t length = 0;
    const bool ok = context != nullptr && EVP_MAC_init(context, key, secret.size(), params) == 1 &&
                    EVP_MAC_update(context, reinterpret_cast<const unsigned char*>(prefix.data()),
                                   prefix.size()) == 1 &&
                    (body.empty() ||
                     EVP_MAC_update(context, reinterpret_cast<const unsigned char*>(body.data()),
                                    body.size()) == 1) &&
                    EVP_MAC_final(context, mac.data(), &length, mac.size()) == 1 &&
                    length == mac.size();
    EVP_MAC_CTX_free(context);
    EVP_MAC_free(hmac);
    if (!ok) return std::nullopt;
    return mac;
}

int HexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    const char lower = absl::ascii_tolower(static_cast<unsigned char>(c));
    if (lower >= 'a' && lower <= 'f') return lower - 'a' + 10;
    return -1;
}

std::optional<Mac> DecodeMac(std::string_view hex) {
    if (hex.size() != 2 * kMacBytes) return std::nullopt;
    Mac mac{};
    for (std::size_t i = 0; i < kMacBytes; ++i) {
        const int high = HexValue(hex[2 * i]);
        const int low = HexValue(hex[2 * i + 1]);
        if (high < 0 || low < 0) return std::nullopt;
        mac[i] = static_cast<unsigned char>(high * 16 + low);
    }
    return mac;
}

struct SignatureFields {
    std::int64_t timestamp = 0;
    std::vector<Mac> signatures;
};

// "t=...,v1=...[,v1=...]" in any order; unknown keys skipped; nullopt when malformed.
std::optional<SignatureFields> ParseSignatureHeader(std::string_view header) {
    if (header.size() > kMaxHeaderLength) return std::nullopt;
    SignatureFields fields;
    bool has_timestamp = false;
    for (const absl::string_view part : absl::StrSplit(AbslView(header), ',')) {
        const absl::string_view stripped = absl::StripAsciiWhitespace(part);
        const std::string_view field(stripped.data(), stripped.size());
        const std::size_t equals = field.find('=');
        if (equals == std::string_view::npos) return std::nullopt;
        const std::string_view key = field.substr(0, equals);
        const std::string_view value = field.substr(equals + 1);
        if (key == "t") {
            if (has_timestamp || value.empty() || value.size() > kMaxTimestampDigits ||
                value.find_first_not_of("0123456789") != std::string_view::npos) {
                return std::nullopt;
            }
            for (char c : value) fields.timestamp = fields.timestamp * 10 + (c - '0');
            has_timestamp = true;
        } else if (key == "v1") {
            std::optional<Mac> mac = DecodeMac(value);
            if (!mac) return std::nullopt;
            fields.signatures.push_back(*mac);
        }
    }
    if (!has_timestamp || fields.signatures.empty()) return std::nullopt;
    return fields;
}

}  // namespace

std::string SignatureHeader(std::string_view secret, std::int64_t unix_seconds,
                            std::string_view body) {
    const std::optional<Mac> mac = ComputeMac(secret, unix_seconds, body);
    if (!mac) return "";
    const std::string_view bytes(reinterpret_cast<const char*>(mac->data()), mac->size());
    return absl::StrCat("t=", unix_seconds, ",v1=", absl::BytesToHexString(AbslView(bytes)));
}

bool VerifySignature(std::string_view header, std::string_view secret, std::string_view body,
                     std::int64_t now_seconds, std::int64_t tolerance_seconds) {
    const std::optional<SignatureFields> fields = ParseSignatureHeader(header);
    if (!fields || tolerance_seconds < 0) return false;
    // The distance in unsigned arithmetic: exact for any pair of int64 values.
    const auto now = static_cast<std::uint64_t>(now_seconds);
    const auto then = static_cast<std::uint64_t>(fields->timestamp);
    const std::uint64_t gap = now_seconds >= fields->timestamp ? now - then : then - now;
    if (gap > static_cast<std::uint64_t>(tolerance_seconds)) return false;
    const std::optional<Mac> expected = ComputeMac(secret, fields->timestamp, body);
    if (!expected) return false;
    bool match = false;
    for (const Mac& signature : fields->signatures) {
        match |= CRYPTO_memcmp(signature.data(), expected->data(), kMacBytes) == 0;
    }
    return match;
}

}  // namespace soilvol::server
