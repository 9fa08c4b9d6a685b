#include "server/auth/token_file.hpp"

#include <openssl/evp.h>

#include <algorithm>
#include <set>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr std::size_t kMaxNameLength = 64;
constexpr std::string_view kHashPrefix = "sha256:";

bool ValidName(absl::string_view name) {
    return !name.empty() && name.size() <= kMaxNameLength &&
           std::all_of(name.begin(), name.end(), [](char c) {
               return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' ||
                      c == '@' || c == '-';
           });
}

absl::StatusOr<Scope> ParseScope(absl::string_view text) {
    for (const Scope scope : {Scope::kRead, Scope::kEstimate, Scope::kAdmin}) {
        if (text == AbslView(ScopeName(scope))) return scope;
    }
    return absl::InvalidArgumentError(
        absl::StrCat("scope '", text, "' is not read, estimate or admin"));
}

int HexDigit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

absl::StatusOr<Sha256> ParseHash(absl::string_view text) {
    if (text.substr(0, kHashPrefix.size()) != AbslView(kHashPrefix) ||
        text.size() != kHashPrefix.size() + 64) {
        return absl::InvalidArgumentError("the hash is not sha256:<64 hex digits>");
    }
    text.remove_prefix(kHashPrefix.size());
    Sha256 hash{};
    for (std::size_t i = 0; i < hash.size(); ++i) {
        const int high = HexDigit(text[2 * i]);
        const int low = HexDigit(text[2 * i + 1]);
        if (high < 0 || low < 0) {
            return absl::InvalidArgumentError("the hash is not sha256:<64 hex digits>");
        }
        hash[i] = static_cast<std::uint8_t>(high * 16 + low);
    }
    return hash;
}

absl::StatusOr<TokenEntry> ParseLine(absl::string_view line) {
    const std::vector<absl::string_view> words =
        absl::StrSplit(line, absl::ByAnyChar(" \t"), absl::SkipEmpty());
    if (words.size() != 3) {
        return absl::InvalidArgumentError("expected '<name> <scopes> sha256:<hex>'");
    }
    TokenEntry entry;
    if (!ValidName(words[0])) {
        return absl::InvalidArgumentError("the name is not 1-64 of [A-Za-z0-9._@-]");
    }
    entry.name = std::string(words[0]);
    for (const absl::string_view text : absl::StrSplit(words[1], ',')) {
        absl::StatusOr<Scope> scope = ParseScope(text);
        if (!scope.ok()) return scope.status();
        if (std::find(entry.scopes.begin(), entry.scopes.end(), *scope) == entry.scopes.end()) {
            entry.scopes.push_back(*scope);
        }
    }
    absl::StatusOr<Sha256> hash = ParseHash(words[2]);
    if (!hash.ok()) return hash.status();
    entry.sha256 = *hash;
    return entry;
}

}  // namespace

std::string_view ScopeName(Scope scope) {
    switch (scope) {
        case Scope::kRead:
            return "read";
        case Scope::kEstimate:
            return "estimate";
        case Scope::kAdmin:
            return "admin";
    }
    return "unknown";
}

bool TokenEntry::Allows(Scope scope) const {
    return std::find(scopes.begin(), scopes.end(), scope) != scopes.end() ||
           std::find(scopes.begin(), scopes.end(), Scope::kAdmin) != scopes.end();
}

absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(std::string_view text) {
    if (text.size() > kMaxTokenFileBytes) {
        return absl::InvalidArgumentError(
            absl::StrCat("token file: more than ", kMaxTokenFileBytes, " bytes"));
    }
    std::vector<TokenEntry> entries;
    std::set<std::string> names;
    std::set<Sha256> hashes;
    int number = 0;
    for (absl::string_view line : absl::StrSplit(AbslView(text), '\n')) {
        ++number;
        line = line.substr(0, line.find('#'));
        line = absl::StripAsciiWhitespace(line);
        if (line.empty()) continue;
        absl::StatusOr<TokenEntry> entry = ParseLine(line);
        if (!entry.ok()) {
            return absl::InvalidArgumentError(
                absl::StrCat("token file line ", number, ": ", entry.status().message()));
        }
        if (!names.insert(entry->name).second || !hashes.insert(entry->sha256).second) {
            return absl::InvalidArgumentError(
                absl::StrCat("token file line ", number, ": repeats a name or a hash"));
        }
        if (entries.size() == kMaxTokens) {
            return absl::InvalidArgumentError(
                absl::StrCat("token file: more than ", kMaxTokens, " tokens"));
        }
        entries.push_back(*std::move(entry));
    }
    return entries;
}

Sha256 Sha256Of(std::string_view data) {
    Sha256 hash{};
    unsigned int size = 0;
    EVP_Digest(data.data(), data.size(), hash.data(), &size, EVP_sha256(), nullptr);
    return hash;
}

}  // namespace soilvol::server
