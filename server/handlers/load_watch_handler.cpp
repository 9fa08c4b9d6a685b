// WatchLoads: every change of a load, with the load as it stood right after it.
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "google/protobuf/util/time_util.h"
#include "server/base/recent_cache.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

/// What the request watches: its haul unit, container and resume point, checked.
absl::StatusOr<LoadEventFeed::Spec> LoadWatchSpec(const v1::WatchLoadsRequest& request) {
    LoadEventFeed::Spec spec;
    if (!request.container_id().empty() && request.container_id() != "-") {
        SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
        spec.container_id = request.container_id();
    }
    if (!request.haul_unit_id().empty()) {
        SOILVOL_RETURN_IF_ERROR(ValidateRequestId(request.haul_unit_id(), "haul_unit_id"));
        spec.match = [haul_unit = request.haul_unit_id()](const LoadEventRecord& row) {
            return row.load.haul_unit_id == haul_unit;
        };
    }
    if (!request.after_event_id().empty()) {
        SOILVOL_ASSIGN_OR_RETURN(spec.after_id,
                                 ParseResumeId(request.after_event_id(), "after_event_id"));
    }
    return spec;
}

v1::LoadEventKind LoadEventKindOf(int kind) {
    switch (kind) {
        case LoadEventRecord::kCreated:
            return v1::LOAD_EVENT_KIND_CREATED;
        case LoadEventRecord::kPassAdded:
            return v1::LOAD_EVENT_KIND_PASS_ADDED;
        case LoadEventRecord::kBodyScanned:
            return v1::LOAD_EVENT_KIND_BODY_SCANNED;
        case LoadEventRecord::kClosed:
            return v1::LOAD_EVENT_KIND_CLOSED;
        default:
            return v1::LOAD_EVENT_KIND_UNSPECIFIED;
    }
}

}  // namespace

absl::Status SoilVolumeHandlers::BuildLoadEvent(const LoadEventRecord& row,
                                                v1::LoadEvent* out) const {
    out->set_event_id(absl::StrCat(row.id));
    out->set_kind(LoadEventKindOf(row.kind));
    *out->mutable_time() = google::protobuf::util::TimeUtil::MicrosecondsToTimestamp(row.time_us);
    if (row.estimate_id > 0) out->set_estimate_id(absl::StrCat(row.estimate_id));
    std::vector<const EstimateRecord*> records;
    for (const EstimateRecord& record : row.records) records.push_back(&record);
    // At the change's time: its state as kept then, not idle-closed since.
    return BuildLoad(row.load, records, row.time_us, out->mutable_load());
}

absl::StatusOr<std::function<void()>> SoilVolumeHandlers::WatchLoads(
    const v1::WatchLoadsRequest& request, LoadEventDeliver deliver,
    std::function<void(const absl::Status&)> ended) {
    SOILVOL_RETURN_IF_ERROR(LoadStore().status());
    SOILVOL_ASSIGN_OR_RETURN(LoadEventFeed::Spec spec, LoadWatchSpec(request));
    auto converted = [this, deliver = std::move(deliver)](const LoadEventRecord* row) {
        if (row == nullptr) return deliver(nullptr);
        // Built once per event, not once per watch (the feed hands a group to each in turn).
        struct Built {
            bool ok = false;
            v1::LoadEvent event;
        };
        thread_local RecentCache<std::int64_t, Built, kFeedGroupRows> built;
        const Built& made = built.Get(row->id, [&](std::int64_t, Built& out) {
            out.event.Clear();
            out.ok = BuildLoadEvent(*row, &out.event).ok();
        });
        // An event whose load or records do not parse is skipped: the watch goes on.
        return !made.ok || deliver(&made.event);
    };
    SOILVOL_ASSIGN_OR_RETURN(
        std::shared_ptr<LoadEventFeed::Watch> watch,
        load_feed_->Start(std::move(spec), std::move(converted), std::move(ended)));
    LoadEventFeed* feed = load_feed_;
    return std::function<void()>([feed, watch] { feed->Stop(watch); });
}

}  // namespace soilvol::server
