// libFuzzer: the REST binding's own parts on any request line and body: route matching with
// percent-decoding of path values, then the body bound to the route's request message as
// grpc-gateway does. The input is "VERB PATH\n" followed by the JSON body.
#include <google/protobuf/util/json_util.h>

#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>

#include "google/protobuf/message.h"
#include "server/http_routes.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace {

const google::protobuf::ServiceDescriptor& Api() {
    return *soilvol::v1::CalibrateRequest::descriptor()->file()->FindServiceByName("SoilVolume");
}

const std::vector<soilvol::server::HttpRoute>& Routes() {
    static const auto* routes = [] {
        auto built = soilvol::server::RoutesFromAnnotations(Api());
        if (!built.ok()) std::abort();
        return new std::vector<soilvol::server::HttpRoute>(*std::move(built));
    }();
    return *routes;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view input(reinterpret_cast<const char*>(data), size);
    const std::size_t space = input.find(' ');
    const std::size_t line_end = input.find('\n');
    if (space == std::string_view::npos || line_end == std::string_view::npos || space > line_end) {
        return 0;
    }
    const std::string verb(input.substr(0, space));
    const std::string path(input.substr(space + 1, line_end - space - 1));
    const auto match = soilvol::server::MatchRoute(Routes(), verb, path);
    if (!match.ok()) return 0;
    if (match->route == nullptr) std::abort();
    const google::protobuf::MethodDescriptor* method = Api().FindMethodByName(match->route->method);
    if (method == nullptr) std::abort();
    std::unique_ptr<google::protobuf::Message> request(
        google::protobuf::MessageFactory::generated_factory()
            ->GetPrototype(method->input_type())
            ->New());
    google::protobuf::util::JsonParseOptions options;
    const std::string body(input.substr(line_end + 1));
    (void)google::protobuf::util::JsonStringToMessage(body, request.get(), options);
    return 0;
}
