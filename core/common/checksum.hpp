#pragma once

#include <cstdint>
#include <string_view>

namespace soilvol {

/// FNV-1a 64-bit offset basis: the seed of a fresh checksum.
inline constexpr uint64_t kFnvOffset = 0xcbf29ce484222325ull;

/// 64-bit FNV-1a of `bytes`. Pass a previous result as `seed` to checksum data given in pieces:
/// Fnv1a64(b, Fnv1a64(a)) == Fnv1a64(a + b). Detects damage, not tampering.
uint64_t Fnv1a64(std::string_view bytes, uint64_t seed = kFnvOffset);

}  // namespace soilvol
