// libFuzzer: the multipart/form-data parser on any body, with the boundary "b0undary". What
// an accepted body must satisfy: every part is a view inside the body, named, and no part's
// data holds the delimiter that would have ended it.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "server/http/multipart.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view body(reinterpret_cast<const char*>(data), size);
    // The first line may choose the Content-Type (and so the boundary) itself.
    std::string boundary = "b0undary";
    if (body.substr(0, 2) == "CT") {
        const std::size_t end = body.find('\n');
        const auto parsed = soilvol::server::MultipartBoundary(body.substr(2, end - 2));
        if (parsed.ok()) boundary = *parsed;
    }
    const auto parts = soilvol::server::ParseMultipart(body, boundary);
    if (!parts.ok()) return 0;
    const std::string delimiter = "\r\n--" + boundary;
    for (const soilvol::server::MultipartPart& part : *parts) {
        const auto inside = [&](std::string_view view) {
            return view.empty() || (view.data() >= body.data() &&
                                    view.data() + view.size() <= body.data() + body.size());
        };
        if (part.name.empty() || !inside(part.name) || !inside(part.filename) ||
            !inside(part.content_type) || !inside(part.data) ||
            part.data.find(delimiter) != std::string_view::npos) {
            std::abort();
        }
    }
    return 0;
}
