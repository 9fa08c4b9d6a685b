#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {

const char* ScalarTypeName(ScalarType type) {
    switch (type) {
        case ScalarType::kInt8:
            return "int8";
        case ScalarType::kUint8:
            return "uint8";
        case ScalarType::kInt16:
            return "int16";
        case ScalarType::kUint16:
            return "uint16";
        case ScalarType::kInt32:
            return "int32";
        case ScalarType::kUint32:
            return "uint32";
        case ScalarType::kFloat32:
            return "float32";
        case ScalarType::kFloat64:
            return "float64";
    }
    return "unknown";
}

std::optional<std::uint64_t> LoadCount(const char* p, ScalarType type, bool swap) {
    switch (type) {
        case ScalarType::kUint8:
            return LoadUnsigned<std::uint8_t>(p, swap);
        case ScalarType::kUint16:
            return LoadUnsigned<std::uint16_t>(p, swap);
        case ScalarType::kUint32:
            return LoadUnsigned<std::uint32_t>(p, swap);
        case ScalarType::kInt8: {
            const auto value = static_cast<std::int8_t>(LoadUnsigned<std::uint8_t>(p, swap));
            if (value < 0) return std::nullopt;
            return static_cast<std::uint64_t>(value);
        }
        case ScalarType::kInt16: {
            const auto value = static_cast<std::int16_t>(LoadUnsigned<std::uint16_t>(p, swap));
            if (value < 0) return std::nullopt;
            return static_cast<std::uint64_t>(value);
        }
        case ScalarType::kInt32: {
            const auto value = static_cast<std::int32_t>(LoadUnsigned<std::uint32_t>(p, swap));
            if (value < 0) return std::nullopt;
            return static_cast<std::uint64_t>(value);
        }
        case ScalarType::kFloat32:
        case ScalarType::kFloat64:
            return std::nullopt;
    }
    return std::nullopt;
}

}  // namespace soilvol::io::detail
