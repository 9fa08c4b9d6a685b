#include "server/http/sse_stream.hpp"

#include <string>
#include <tuple>
#include <utility>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "server/base/recent_cache.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {

SseStream::SseStream(std::shared_ptr<HttpExchange> exchange, std::string event,
                     std::string id_field)
    : exchange_(std::move(exchange)), event_(std::move(event)), id_field_(std::move(id_field)) {}

bool SseStream::Send(std::string chunk) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!started_) {
        pending_.push_back(std::move(chunk));
        return true;
    }
    return exchange_->Send(std::move(chunk));
}

bool SseStream::Deliver(const google::protobuf::Message* message) {
    if (message == nullptr) return Send(": keepalive\n\n");
    const google::protobuf::FieldDescriptor* id =
        message->GetDescriptor()->FindFieldByName(id_field_);
    const std::string event_id =
        id != nullptr ? message->GetReflection()->GetString(*message, id) : "";
    // A feed delivers a group of messages to every stream in turn on its thread: each event is
    // rendered once (JSON printing was most of a delivery's cost) and copied to each stream;
    // the streams of a feed may take two views of each row.
    using Key = std::tuple<const google::protobuf::Message*, std::string, std::string>;
    struct Rendered {
        bool ok = false;
        std::string chunk;
    };
    thread_local RecentCache<Key, Rendered, 2 * kFeedGroupRows> rendered;
    const Rendered& event =
        rendered.Get(Key{message, event_id, event_}, [&](const Key&, Rendered& out) {
            std::string json;
            out.ok = google::protobuf::util::MessageToJsonString(*message, &json).ok();
            out.chunk =
                absl::StrCat("id: ", event_id, "\nevent: ", event_, "\ndata: ", json, "\n\n");
        });
    return !event.ok || Send(event.chunk);
}

void SseStream::End(const absl::Status& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    exchange_->Send(absl::StrCat("event: error\ndata: ", ErrorJson(status), "\n\n"));
    exchange_->Finish();
}

bool SseStream::Start(HttpResponse head) {
    head.content_type = "text/event-stream";
    head.headers.Set("Cache-Control", "no-cache");
    head.headers.Set("X-Accel-Buffering", "no");  // proxies: pass each event on at once
    std::lock_guard<std::mutex> lock(mutex_);
    if (!exchange_->StartStream(std::move(head))) return false;
    started_ = true;
    // The retry hint, then what arrived meanwhile.
    exchange_->Send("retry: 1000\n: watching\n\n");
    for (std::string& chunk : pending_) exchange_->Send(std::move(chunk));
    pending_.clear();
    return true;
}

}  // namespace soilvol::server
