#include "core/common/checksum.hpp"

namespace soilvol {
namespace {

constexpr uint64_t kFnvPrime = 0x100000001b3ull;

}  // namespace

uint64_t Fnv1a64(std::string_view bytes, uint64_t seed) {
    uint64_t hash = seed;
    for (const char c : bytes) {
        hash ^= static_cast<uint8_t>(c);
        hash *= kFnvPrime;
    }
    return hash;
}

}  // namespace soilvol
