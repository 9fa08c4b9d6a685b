#pragma once

// Private to core/io: scalar types, checked size arithmetic and byte-order aware loads.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <string>

namespace soilvol::io::detail {

/// Scalar storage types shared by the PLY and PCD codecs.
enum class ScalarType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

inline constexpr bool kHostIsLittleEndian = __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__;

/// Size of one value [bytes].
inline std::size_t ScalarSize(ScalarType type) {
    switch (type) {
        case ScalarType::kInt8:
        case ScalarType::kUint8:
            return 1;
        case ScalarType::kInt16:
        case ScalarType::kUint16:
            return 2;
        case ScalarType::kInt32:
        case ScalarType::kUint32:
        case ScalarType::kFloat32:
            return 4;
        case ScalarType::kFloat64:
            return 8;
    }
    return 8;
}

inline bool IsFloating(ScalarType type) {
    return type == ScalarType::kFloat32 || type == ScalarType::kFloat64;
}

/// Name for error messages ("int32", "float64", ...).
const char* ScalarTypeName(ScalarType type);

/// `a * b` into `product`; false when it overflows 64 bits.
inline bool CheckedMul(std::uint64_t a, std::uint64_t b, std::uint64_t* product) {
    return !__builtin_mul_overflow(a, b, product);
}

/// `a + b` into `sum`; false when it overflows 64 bits.
inline bool CheckedAdd(std::uint64_t a, std::uint64_t b, std::uint64_t* sum) {
    return !__builtin_add_overflow(a, b, sum);
}

/// Reads an unsigned integer of sizeof(T) bytes at `p`, byte-swapped when `swap`.
template <typename T>
T LoadUnsigned(const char* p, bool swap) {
    T value;
    std::memcpy(&value, p, sizeof(T));
    if (!swap) return value;
    if constexpr (sizeof(T) == 2) return __builtin_bswap16(value);
    if constexpr (sizeof(T) == 4) return __builtin_bswap32(value);
    if constexpr (sizeof(T) == 8) return __builtin_bswap64(value);
    return value;
}

/// Converts to float, mapping magnitudes beyond the float range to +-Inf (no UB).
inline float NarrowToFloat(double value) {
    constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
    if (value > kMax) return std::numeric_limits<float>::infinity();
    if (value < -kMax) return -std::numeric_limits<float>::infinity();
    return static_cast<float>(value);
}

/// Reads a float32 or float64 coordinate at `p` as float.
inline float LoadCoordinate(const char* p, ScalarType type, bool swap) {
    if (type == ScalarType::kFloat64) {
        const std::uint64_t bits = LoadUnsigned<std::uint64_t>(p, swap);
        double value;
        std::memcpy(&value, &bits, sizeof(value));
        return NarrowToFloat(value);
    }
    const std::uint32_t bits = LoadUnsigned<std::uint32_t>(p, swap);
    float value;
    std::memcpy(&value, &bits, sizeof(value));
    return value;
}

/// Reads an integer list count at `p`; nullopt for a negative or non-integer type.
std::optional<std::uint64_t> LoadCount(const char* p, ScalarType type, bool swap);

/// Appends `value` as 4 bytes, big-endian when `big_endian`.
inline void AppendFloat32(float value, bool big_endian, std::string* out) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, sizeof(bits));
    if (big_endian == kHostIsLittleEndian) bits = __builtin_bswap32(bits);
    out->append(reinterpret_cast<const char*>(&bits), sizeof(bits));
}

/// Appends `value` as 4 little-endian bytes.
inline void AppendUint32Le(std::uint32_t value, std::string* out) {
    if (!kHostIsLittleEndian) value = __builtin_bswap32(value);
    out->append(reinterpret_cast<const char*>(&value), sizeof(value));
}

}  // namespace soilvol::io::detail
