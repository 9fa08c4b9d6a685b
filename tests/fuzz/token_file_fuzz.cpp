// libFuzzer: the token file reader (--auth-tokens-file) on any bytes. An accepted file has
// valid names, at least one scope per token, and no repeated name or hash.
#include <cstdint>
#include <cstdlib>
#include <set>
#include <string>
#include <string_view>

#include "server/auth/token_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const auto tokens = soilvol::server::ParseTokenFile(text);
    if (!tokens.ok()) return 0;
    std::set<std::string> names;
    std::set<soilvol::server::Sha256> hashes;
    for (const auto& token : *tokens) {
        if (token.name.empty() || token.name.size() > 64 || token.scopes.empty()) std::abort();
        if (!names.insert(token.name).second || !hashes.insert(token.sha256).second) std::abort();
    }
    if (tokens->size() > soilvol::server::kMaxTokens) std::abort();
    return 0;
}
