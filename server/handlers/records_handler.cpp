#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/recent_cache.hpp"
#include "server/base/status_map.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

/// The API message of a stored record, its heightmap left out for the BASIC view.
absl::Status FromRecord(const EstimateRecord& row, bool full, v1::Estimate* out) {
    if (!out->ParseFromString(row.payload)) {
        return absl::DataLossError(
            absl::StrCat("estimate ", row.id, ": the stored record does not parse"));
    }
    out->set_estimate_id(absl::StrCat(row.id));
    out->mutable_result()->set_estimate_id(out->estimate_id());
    if (!full) out->mutable_result()->clear_heightmap();
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<EstimateRecorder*> SoilVolumeHandlers::Recorder() const {
    if (recorder_ == nullptr) {
        return absl::FailedPreconditionError("records are off on this server (--records-url none)");
    }
    return recorder_;
}

void SoilVolumeHandlers::RecordEstimate(const v1::EstimateVolumeRequest& request,
                                        v1::EstimateVolumeResponse* response,
                                        std::optional<LoadLink> load, Measures measures,
                                        CallRecord& record) {
    if (!Records(request)) return;
    v1::Estimate kept;
    *kept.mutable_create_time() = NowTimestamp();
    kept.set_container_id(request.container_id());
    kept.set_request_id(request.request_id());
    *kept.mutable_result() = *response;
    EstimateRecord row;
    row.container_id = request.container_id();
    row.create_time_us = TimeUtil::TimestampToMicroseconds(kept.create_time());
    row.request_id = request.request_id();
    row.registration_id = response->registration_id();
    row.payload = kept.SerializeAsString();
    row.load = std::move(load);
    row.measures = std::move(measures);
    for (const v1::Alert& alert : response->alerts()) row.alerts.push_back(ToAlertRecord(alert));
    // The dispatcher hands the completion over once the handler returned, so the response
    // is no longer written on the worker when the commit sets its id.
    record.finish_later = [recorder = recorder_, row = std::move(row),
                           answer = response](std::function<void(absl::Status)> finish) mutable {
        recorder->RecordAsync(
            std::move(row), [answer, finish = std::move(finish)](absl::StatusOr<std::int64_t> id) {
                if (absl::IsFailedPrecondition(id.status()) || absl::IsNotFound(id.status())) {
                    finish(id.status());  // its load refused it (closed, or gone) meanwhile
                    return;
                }
                if (!id.ok()) {
                    finish(absl::UnavailableError(absl::StrCat(
                        "the estimate could not be recorded (retry, or set skip_record): ",
                        id.status().message())));
                    return;
                }
                answer->set_estimate_id(absl::StrCat(*id));
                finish(absl::OkStatus());
            });
    };
}

absl::Status SoilVolumeHandlers::GetEstimate(const v1::GetEstimateRequest& request,
                                             v1::Estimate* response, CallRecord& record) {
    record.ids.push_back({"container", request.container_id()});
    SOILVOL_ASSIGN_OR_RETURN(EstimateRecorder * recorder, Recorder());
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
    SOILVOL_ASSIGN_OR_RETURN(const std::int64_t id,
                             ParseRecordId(request.estimate_id(), "estimate_id"));
    const absl::StatusOr<EstimateRecord> row = recorder->store().Get(request.container_id(), id);
    if (!row.ok()) return Annotate(row.status(), "estimate_id");
    return FromRecord(*row, request.view() != v1::ESTIMATE_VIEW_BASIC, response);
}

absl::StatusOr<std::string> SoilVolumeHandlers::RegistrationFilter(
    const v1::ListEstimatesRequest& request) {
    const std::string& wanted = request.registration_id();
    if (wanted == "-") return std::string();
    if (!wanted.empty()) {
        SOILVOL_RETURN_IF_ERROR(ValidateId(wanted, "registration_id"));
        return wanted;
    }
    if (request.container_id() == "-") return std::string();
    const auto container = LoadContainer(request.container_id(), "container_id");
    if (absl::IsNotFound(container.status())) return std::string();  // deleted: all its records
    SOILVOL_RETURN_IF_ERROR(container.status());
    return (*container)->info.registration_id();
}

absl::Status SoilVolumeHandlers::ListEstimates(const v1::ListEstimatesRequest& request,
                                               v1::ListEstimatesResponse* response, CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(EstimateRecorder * recorder, Recorder());
    RecordQuery query;
    if (request.container_id() != "-") {
        SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
        query.container_id = request.container_id();
    }
    SOILVOL_ASSIGN_OR_RETURN(query.registration_id, RegistrationFilter(request));
    SOILVOL_ASSIGN_OR_RETURN(const int size, PageSizeOf(request.page_size()));
    SOILVOL_ASSIGN_OR_RETURN(query.before_id, ParseRecordPageToken(request.page_token()));
    SOILVOL_RETURN_IF_ERROR(
        TimeRangeMicros(request.has_start_time() ? &request.start_time() : nullptr,
                        request.has_end_time() ? &request.end_time() : nullptr,
                        &query.start_time_us, &query.end_time_us));
    query.limit = size + 1;  // one more tells whether there is a next page
    SOILVOL_ASSIGN_OR_RETURN(std::vector<EstimateRecord> rows, recorder->store().List(query));
    const bool more = rows.size() > static_cast<std::size_t>(size);
    if (more) rows.resize(static_cast<std::size_t>(size));
    for (const EstimateRecord& row : rows) {
        SOILVOL_RETURN_IF_ERROR(
            FromRecord(row, request.view() == v1::ESTIMATE_VIEW_FULL, response->add_estimates()));
    }
    if (more && !rows.empty()) response->set_next_page_token(RecordPageToken(rows.back().id));
    return absl::OkStatus();
}

absl::StatusOr<std::function<void()>> SoilVolumeHandlers::WatchEstimates(
    const v1::WatchEstimatesRequest& request, WatchDeliver deliver, WatchEnded ended) {
    SOILVOL_RETURN_IF_ERROR(Recorder().status());
    EstimateFeed::Spec spec;
    if (!request.container_id().empty() && request.container_id() != "-") {
        SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
        // A watch of a container that does not exist would wait for ever: NOT_FOUND, as Get.
        SOILVOL_RETURN_IF_ERROR(LoadContainer(request.container_id(), "container_id").status());
        spec.container_id = request.container_id();
    }
    if (!request.after_estimate_id().empty()) {
        SOILVOL_ASSIGN_OR_RETURN(spec.after_id,
                                 ParseResumeId(request.after_estimate_id(), "after_estimate_id"));
    }
    const bool full = request.view() == v1::ESTIMATE_VIEW_FULL;
    auto converted = [deliver = std::move(deliver), full](const EstimateRecord* row) {
        if (row == nullptr) return deliver(nullptr);
        // The feed hands a group of records to every watch in turn on its one thread: each is
        // parsed once per view, not once per watch (1000 watches: 34 ms of CPU per record
        // before), and the same message goes to each (SseStream renders it once too).
        struct Parsed {
            bool ok = false;
            v1::Estimate estimate;
        };
        thread_local RecentCache<std::int64_t, Parsed, kFeedGroupRows> parsed[2];
        const Parsed& made = parsed[full ? 1 : 0].Get(row->id, [&](std::int64_t, Parsed& out) {
            out.estimate.Clear();
            out.ok = FromRecord(*row, full, &out.estimate).ok();
        });
        // A record that does not parse is skipped: the watch goes on.
        return !made.ok || deliver(&made.estimate);
    };
    SOILVOL_ASSIGN_OR_RETURN(std::shared_ptr<EstimateFeed::Watch> watch,
                             feed_->Start(std::move(spec), std::move(converted), std::move(ended)));
    EstimateFeed* feed = feed_;
    return std::function<void()>([feed, watch] { feed->Stop(watch); });
}

}  // namespace soilvol::server
