#include "server/auth/authenticator.hpp"

#include <openssl/crypto.h>

#include <array>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"
#include "server/base/logging.hpp"

namespace soilvol::server {
namespace {

constexpr std::size_t kMinTokenLength = 16;
constexpr std::size_t kMaxTokenLength = 4096;

struct MethodScope {
    std::string_view method;
    Scope scope;
};

constexpr std::array<MethodScope, 25> kMethodScopes = {{
    {"Calibrate", Scope::kAdmin},
    {"GetCalibration", Scope::kRead},
    {"ListCalibrations", Scope::kRead},
    {"DeleteCalibration", Scope::kAdmin},
    {"RegisterContainer", Scope::kAdmin},
    {"GetContainer", Scope::kRead},
    {"ListContainers", Scope::kRead},
    {"UpdateContainer", Scope::kAdmin},
    {"DeleteContainer", Scope::kAdmin},
    {"GetEstimate", Scope::kRead},
    {"ListEstimates", Scope::kRead},
    {"WatchEstimates", Scope::kRead},
    {"EstimateVolume", Scope::kEstimate},
    {"StreamEstimates", Scope::kEstimate},
    {"GetServerInfo", Scope::kRead},
    // Loads are the fleet's day, as estimates are: a dispatcher opens and closes them.
    {"CreateLoad", Scope::kEstimate},
    {"CloseLoad", Scope::kEstimate},
    {"GetLoad", Scope::kRead},
    {"ListLoads", Scope::kRead},
    {"GetProduction", Scope::kRead},
    {"ListAlerts", Scope::kRead},
    {"WatchAlerts", Scope::kRead},
    {"WatchLoads", Scope::kRead},
    // A webhook's URL may carry the receiver's credentials in its query.
    {"ListWebhooks", Scope::kAdmin},
    {"ListWebhookDeliveries", Scope::kAdmin},
}};

// "Bearer <token>" (the scheme in any case, RFC 7235); "" when the header is something else.
std::string_view BearerToken(std::string_view authorization) {
    constexpr std::string_view kScheme = "bearer ";
    if (authorization.size() <= kScheme.size() ||
        !absl::StartsWithIgnoreCase(AbslView(authorization), AbslView(kScheme))) {
        return {};
    }
    const absl::string_view token =
        absl::StripAsciiWhitespace(AbslView(authorization.substr(kScheme.size())));
    return {token.data(), token.size()};
}

bool PrintableToken(std::string_view token) {
    for (const char c : token) {
        if (c <= ' ' || c > '~') return false;
    }
    return token.size() >= kMinTokenLength && token.size() <= kMaxTokenLength;
}

}  // namespace

absl::StatusOr<Scope> RequiredScope(std::string_view method) {
    for (const MethodScope& entry : kMethodScopes) {
        if (entry.method == method) return entry.scope;
    }
    return absl::NotFoundError(
        absl::StrCat("no scope is defined for method '", AbslView(method), "'"));
}

absl::StatusOr<std::vector<TokenEntry>> LoadTokenFile(const std::string& path) {
    absl::StatusOr<std::string> text = ReadSmallFile(path, kMaxTokenFileBytes, "auth-tokens-file");
    if (!text.ok()) return text.status();
    absl::StatusOr<std::vector<TokenEntry>> tokens = ParseTokenFile(*text);
    if (!tokens.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("--auth-tokens-file: ", tokens.status().message()));
    }
    return tokens;
}

Authenticator::Authenticator(AuthOptions options)
    : options_(std::move(options)), watched_({options_.tokens_file}, options_.reload_check) {}

absl::StatusOr<std::unique_ptr<Authenticator>> Authenticator::Create(AuthOptions options) {
    std::unique_ptr<Authenticator> authenticator(new Authenticator(std::move(options)));
    if (!authenticator->options_.tokens_file.empty()) {
        authenticator->watched_.Mark();
        absl::StatusOr<std::vector<TokenEntry>> tokens =
            LoadTokenFile(authenticator->options_.tokens_file);
        if (!tokens.ok()) return tokens.status();
        authenticator->tokens_ =
            std::make_shared<const std::vector<TokenEntry>>(*std::move(tokens));
    }
    return authenticator;
}

std::shared_ptr<const std::vector<TokenEntry>> Authenticator::Tokens() const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (watched_.Changed()) {
        watched_.Mark();
        absl::StatusOr<std::vector<TokenEntry>> tokens = LoadTokenFile(options_.tokens_file);
        if (tokens.ok()) {
            tokens_ = std::make_shared<const std::vector<TokenEntry>>(*std::move(tokens));
            LogEvent(LogLevel::kInfo, "tokens reloaded", {{"tokens", tokens_->size()}});
        } else {
            LogEvent(LogLevel::kError, "tokens not reloaded, the previous ones stay",
                     {{"error", tokens.status().message()}});
        }
    }
    return tokens_;
}

absl::Status Authenticator::Authorize(Scope needed, std::string_view authorization,
                                      std::string_view tls_identity, Principal* who) const {
    if (options_.tokens_file.empty()) {
        if (options_.client_certificates && !tls_identity.empty()) {
            *who = {std::string(tls_identity), "certificate"};
            return absl::OkStatus();
        }
        if (options_.client_certificates) {
            return absl::UnauthenticatedError("a verified client certificate is required");
        }
        *who = {"anonymous", "none"};
        return absl::OkStatus();
    }
    const std::string_view token = BearerToken(authorization);
    if (token.empty()) {
        return absl::UnauthenticatedError(
            "authorization: a bearer token is required (Authorization: Bearer <token>)");
    }
    if (!PrintableToken(token)) {
        return absl::UnauthenticatedError("authorization: the token is not valid");
    }
    const Sha256 presented = Sha256Of(token);
    const std::shared_ptr<const std::vector<TokenEntry>> tokens = Tokens();
    // Every hash is compared, in constant time, whichever matches.
    const TokenEntry* match = nullptr;
    for (const TokenEntry& entry : *tokens) {
        const bool same =
            CRYPTO_memcmp(entry.sha256.data(), presented.data(), presented.size()) == 0;
        if (same) match = &entry;
    }
    if (match == nullptr)
        return absl::UnauthenticatedError("authorization: the token is not valid");
    who->name = match->name;
    if (!tls_identity.empty()) absl::StrAppend(&who->name, " (", AbslView(tls_identity), ")");
    who->via = "token";
    if (!match->Allows(needed)) {
        return absl::PermissionDeniedError(
            absl::StrCat("the token '", match->name, "' lacks the scope '",
                         AbslView(ScopeName(needed)), "' this call needs"));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
