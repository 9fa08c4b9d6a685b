// libFuzzer: the REST binding's own parts on any request line and body: route matching with
// percent-decoding of path values, then the body, path values and query parameters bound to the
// route's request message as grpc-gateway does (server::BindRequest). The input is
// "VERB PATH[?QUERY][ CONTENT-TYPE]\n" followed by the body (JSON by default; binary and
// multipart/form-data bodies when the content type says so).
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <string>
#include <string_view>

#include "google/protobuf/message.h"
#include "server/http/grpc_timeout.hpp"
#include "server/http/http_routes.hpp"
#include "server/http/json_input.hpp"
#include "server/http/query_string.hpp"
#include "server/http/request_binding.hpp"
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
    const std::string_view rest = input.substr(space + 1, line_end - space - 1);
    const std::size_t type_at = rest.find(' ');
    const std::string target(rest.substr(0, type_at));
    const std::string content_type = type_at == std::string_view::npos
                                         ? std::string("application/json")
                                         : std::string(rest.substr(type_at + 1));
    const std::size_t question = target.find('?');
    const std::string path = target.substr(0, question);
    const std::string query = question == std::string::npos ? "" : target.substr(question + 1);
    // An export path names its list's path, and keeps every query part but its format.
    if (const auto exported = soilvol::server::ExportPathOf(path, query)) {
        if (path.compare(0, exported->list_path.size(), exported->list_path) != 0 ||
            exported->query.size() > query.size() || exported->format.size() > query.size() + 3) {
            std::abort();
        }
    }
    const auto match = soilvol::server::MatchRoute(Routes(), verb, path);
    if (!match.ok()) return 0;
    if (match->route == nullptr) std::abort();
    const google::protobuf::MethodDescriptor* method = Api().FindMethodByName(match->route->method);
    if (method == nullptr) std::abort();
    std::unique_ptr<google::protobuf::Message> request(
        google::protobuf::MessageFactory::generated_factory()
            ->GetPrototype(method->input_type())
            ->New());
    std::string body(input.substr(line_end + 1));
    const absl::Status bound = soilvol::server::BindRequest(*match->route, match->fields, query,
                                                            content_type, body, request.get());
    // A bound request keeps every path value it was given.
    for (const auto& [field, value] : match->fields) {
        const auto* descriptor = request->GetDescriptor()->FindFieldByName(field);
        if (bound.ok() && (descriptor == nullptr ||
                           request->GetReflection()->GetString(*request, descriptor) != value)) {
            std::abort();
        }
    }
    return 0;
}
