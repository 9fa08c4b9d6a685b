#include "server/http/http_message.hpp"

#include <algorithm>

#include "absl/strings/match.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

const std::string kEmpty;

}  // namespace

void HttpHeaders::Add(std::string name, std::string value) {
    fields_.emplace_back(std::move(name), std::move(value));
}

void HttpHeaders::Set(const std::string& name, std::string value) {
    fields_.erase(std::remove_if(
                      fields_.begin(), fields_.end(),
                      [&](const auto& field) { return absl::EqualsIgnoreCase(field.first, name); }),
                  fields_.end());
    fields_.emplace_back(name, std::move(value));
}

const std::string& HttpHeaders::Get(std::string_view name) const {
    for (const auto& [field, value] : fields_) {
        if (absl::EqualsIgnoreCase(field, AbslView(name))) return value;
    }
    return kEmpty;
}

bool HttpHeaders::Has(std::string_view name) const {
    return std::any_of(fields_.begin(), fields_.end(), [&](const auto& field) {
        return absl::EqualsIgnoreCase(field.first, AbslView(name));
    });
}

HttpResponse JsonResponse(int status, std::string body) {
    HttpResponse response;
    response.status = status;
    response.body = std::move(body);
    return response;
}

}  // namespace soilvol::server
