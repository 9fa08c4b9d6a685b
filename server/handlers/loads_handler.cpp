#include <cmath>
#include <map>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/volume/load_totals.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

google::protobuf::Timestamp TimeOf(std::int64_t micros) {
    return TimeUtil::MicrosecondsToTimestamp(micros);
}

/// A pass's figures from its record (see volume::SumPasses).
volume::PassFigures PassOf(const v1::Estimate& estimate) {
    const v1::EstimateVolumeResponse& result = estimate.result();
    volume::PassFigures pass;
    pass.volume_m3 = result.volume_m3();
    pass.sigma_m3 = result.uncertainty_m3();
    // What repeats from pass to pass: the registration's error, and the strip the scan could
    // not see - the same walls hidden from the same mount, filled the same way each pass.
    pass.shared_sigma_m3 = std::hypot(result.coverage().capacity_uncertainty_m3(),
                                      result.coverage().unobserved_uncertainty_m3());
    // Records from before registrations had ids share by container.
    pass.registration = result.registration_id().empty()
                            ? absl::StrCat("container:", estimate.container_id())
                            : result.registration_id();
    if (result.load().bank_volume_m3() > 0.0 && result.volume_m3() > 0.0) {
        pass.bulking_factor = result.volume_m3() / result.load().bank_volume_m3();
    }
    if (result.has_mass_kg()) {
        pass.density_kg_m3 = result.volume_m3() > 0.0 ? result.mass_kg() / result.volume_m3() : 0.0;
    }
    pass.time_us = TimeUtil::TimestampToMicroseconds(estimate.create_time());
    return pass;
}

void SetTotals(const volume::LoadTotals& totals, v1::Load* out) {
    out->set_pass_count(totals.passes);
    out->set_volume_m3(totals.volume_m3);
    out->set_uncertainty_m3(totals.sigma_m3);
    out->set_bank_volume_m3(totals.bank_volume_m3);
    out->set_bank_uncertainty_m3(totals.bank_sigma_m3);
    if (totals.mass_kg) out->set_mass_kg(*totals.mass_kg);
    if (totals.mass_sigma_kg) out->set_mass_uncertainty_kg(*totals.mass_sigma_kg);
    if (totals.passes > 0) {
        *out->mutable_first_pass_time() = TimeOf(totals.first_time_us);
        *out->mutable_last_pass_time() = TimeOf(totals.last_time_us);
    }
    out->set_mean_cycle_seconds(totals.mean_cycle_s.value_or(0.0));
}

void SetReconciliation(const volume::LoadTotals& totals, const v1::Estimate& body, v1::Load* out) {
    const volume::Reconciliation r =
        volume::Reconcile(totals, body.result().volume_m3(), body.result().uncertainty_m3());
    v1::LoadReconciliation* proto = out->mutable_reconciliation();
    proto->set_estimate_id(body.estimate_id());
    *proto->mutable_scan_time() = body.create_time();
    proto->set_passes_volume_m3(r.passes_m3);
    proto->set_body_volume_m3(r.body_m3);
    proto->set_body_uncertainty_m3(body.result().uncertainty_m3());
    proto->set_difference_m3(r.difference_m3);
    proto->set_combined_uncertainty_m3(r.combined_sigma_m3);
    proto->set_difference_sigmas(r.difference_sigmas);
    proto->set_within_two_sigma(r.within_two_sigma);
}

/// The state, reasons, times and etag of `row` as it stands at `now_us`.
void SetLifecycle(const LoadRecord& row, std::int64_t now_us, std::int64_t idle_us, v1::Load* out) {
    out->set_etag(absl::StrCat(row.revision));  // the stored revision: what CloseLoad checks
    LoadRecord now = row;
    ApplyIdleClose(now, now_us, idle_us);
    out->set_load_id(now.load_id);
    out->set_haul_unit_id(now.haul_unit_id);
    out->set_body_container_id(now.body_container_id);
    out->set_state(now.state == LoadRecord::kOpen ? v1::LOAD_STATE_OPEN : v1::LOAD_STATE_CLOSED);
    out->set_close_reason(static_cast<v1::LoadCloseReason>(now.close_reason));
    *out->mutable_create_time() = TimeOf(now.create_time_us);
    *out->mutable_update_time() = TimeOf(now.update_time_us);
    if (now.state == LoadRecord::kClosed) *out->mutable_close_time() = TimeOf(now.close_time_us);
    out->set_create_request_id(now.request_id);
}

/// The load's client fields, checked (CreateLoad).
absl::Status CheckLoadFields(const v1::Load& load) {
    if (load.haul_unit_id().empty()) {
        return absl::InvalidArgumentError("load.haul_unit_id: required");
    }
    SOILVOL_RETURN_IF_ERROR(ValidateRequestId(load.haul_unit_id(), "load.haul_unit_id"));
    if (!load.body_container_id().empty()) {
        SOILVOL_RETURN_IF_ERROR(ValidateId(load.body_container_id(), "load.body_container_id"));
    }
    SOILVOL_RETURN_IF_ERROR(ValidateDisplayName(load.display_name(), "load.display_name"));
    if (load.labels_size() > kMaxLabels) {
        return absl::InvalidArgumentError(absl::StrCat("load.labels: at most ", kMaxLabels));
    }
    for (const auto& [key, value] : load.labels()) {
        SOILVOL_RETURN_IF_ERROR(ValidateLabel(key, value, "load.labels"));
    }
    // A payload target is judged through the passes' densities: any density checks the rest.
    v1::Material material;
    material.set_density_kg_m3(1000.0);
    const absl::StatusOr<LoadRules> rules = ToLoadRules(material, load.targets());
    if (!rules.ok()) {
        return absl::InvalidArgumentError(absl::StrCat("load.", rules.status().message()));
    }
    return absl::OkStatus();
}

/// What CreateLoad keeps of the request's load: the fields a client sets.
v1::Load ClientFields(const v1::Load& load) {
    v1::Load kept;
    kept.set_haul_unit_id(load.haul_unit_id());
    kept.set_body_container_id(load.body_container_id());
    if (load.has_targets()) *kept.mutable_targets() = load.targets();
    kept.set_display_name(load.display_name());
    *kept.mutable_labels() = load.labels();
    return kept;
}

}  // namespace

absl::StatusOr<RecordStore*> SoilVolumeHandlers::LoadStore() const {
    if (recorder_ == nullptr) {
        return absl::FailedPreconditionError(
            "loads are kept with the records, which are off on this server (--records-url none)");
    }
    return &recorder_->store();
}

void SoilVolumeHandlers::AssessTotals(const volume::LoadTotals& totals, v1::Load* out) const {
    v1::LoadTargets targets = out->targets();
    if (!out->has_targets() && !out->body_container_id().empty()) {
        const auto body = LoadContainer(out->body_container_id(), "body_container_id");
        if (body.ok()) targets = (*body)->info.load_targets();
    }
    v1::Material material;
    if (totals.mass_kg && totals.volume_m3 > 0.0) {
        material.set_density_kg_m3(*totals.mass_kg / totals.volume_m3);
    }
    absl::StatusOr<LoadRules> rules = ToLoadRules(material, targets);
    if (!rules.ok()) rules = ToLoadRules(material, v1::LoadTargets());  // payload, no mass
    if (!rules.ok()) rules = LoadRules();
    rules->material.bulking_factor =
        totals.bank_volume_m3 > 0.0 ? totals.volume_m3 / totals.bank_volume_m3 : 1.0;
    const volume::LoadAssessment assessment =
        volume::AssessLoad(totals.volume_m3, totals.sigma_m3, rules->material, rules->targets);
    ToProto(assessment, out->mutable_assessment());
    out->mutable_assessment()->set_bank_volume_m3(totals.bank_volume_m3);
    if (totals.mass_sigma_kg) {
        out->mutable_assessment()->set_mass_uncertainty_kg(*totals.mass_sigma_kg);
    }
}

absl::Status SoilVolumeHandlers::BuildLoad(const LoadRecord& row,
                                           const std::vector<const EstimateRecord*>& records,
                                           std::int64_t now_us, v1::Load* out) const {
    if (!out->ParseFromString(row.payload)) {
        return absl::DataLossError(
            absl::StrCat("load '", row.load_id, "': the stored load does not parse"));
    }
    SetLifecycle(row, now_us, options_.load_idle_us, out);
    std::vector<volume::PassFigures> passes;
    std::optional<v1::Estimate> body;
    for (const EstimateRecord* record : records) {
        v1::Estimate estimate;
        if (!estimate.ParseFromString(record->payload)) {
            return absl::DataLossError(
                absl::StrCat("estimate ", record->id, ": the stored record does not parse"));
        }
        estimate.set_estimate_id(absl::StrCat(record->id));
        if (record->load && record->load->role == LoadLink::kBodyScan) {
            body = std::move(estimate);  // oldest first: the latest wins
            continue;
        }
        passes.push_back(PassOf(estimate));
        v1::LoadPass* pass = out->add_passes();
        pass->set_container_id(estimate.container_id());
        pass->set_estimate_id(estimate.estimate_id());
        *pass->mutable_create_time() = estimate.create_time();
        pass->set_volume_m3(estimate.result().volume_m3());
        pass->set_uncertainty_m3(estimate.result().uncertainty_m3());
    }
    const volume::LoadTotals totals = volume::SumPasses(passes);
    SetTotals(totals, out);
    AssessTotals(totals, out);
    if (body) SetReconciliation(totals, *body, out);
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::BuildLoads(const std::vector<LoadRecord>& rows,
                                            std::vector<v1::Load*> outs) const {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    std::vector<std::string> ids;
    for (const LoadRecord& row : rows) ids.push_back(row.load_id);
    SOILVOL_ASSIGN_OR_RETURN(const std::vector<EstimateRecord> records, store->LoadEstimates(ids));
    std::map<std::string, std::vector<const EstimateRecord*>> by_load;
    for (const EstimateRecord& record : records) by_load[record.load->load_id].push_back(&record);
    const std::int64_t now_us = NowMicros();
    for (std::size_t i = 0; i < rows.size(); ++i) {
        SOILVOL_RETURN_IF_ERROR(BuildLoad(rows[i], by_load[rows[i].load_id], now_us, outs[i]));
    }
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::CreateLoad(const v1::CreateLoadRequest& request,
                                            v1::Load* response, CallRecord& record) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    SOILVOL_RETURN_IF_ERROR(ValidateRequestId(request.request_id(), "request_id"));
    std::string id = request.load_id();
    if (id.empty()) id = ServerChosenId("load", request.request_id());
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, "load_id"));
    record.ids.push_back({"load", id});
    SOILVOL_RETURN_IF_ERROR(CheckLoadFields(request.load()));
    if (!request.load().body_container_id().empty()) {
        SOILVOL_RETURN_IF_ERROR(
            LoadContainer(request.load().body_container_id(), "load.body_container_id").status());
    }
    LoadRecord row;
    row.load_id = id;
    row.haul_unit_id = request.load().haul_unit_id();
    row.body_container_id = request.load().body_container_id();
    row.create_time_us = row.update_time_us = row.last_activity_us = NowMicros();
    row.request_id = request.request_id();
    row.payload = ClientFields(request.load()).SerializeAsString();
    absl::Status created = store->CreateLoad(row, options_.load_idle_us);
    if (absl::IsAlreadyExists(created) && !request.request_id().empty()) {
        SOILVOL_ASSIGN_OR_RETURN(row, store->GetLoad(id));  // a retry gets the first result
        if (row.request_id != request.request_id()) return created;
        created = absl::OkStatus();
    }
    SOILVOL_RETURN_IF_ERROR(created);
    JudgeClosed();             // the haul unit's previous load, closed by this one
    recorder_->WakeWaiters();  // the watches: the load's events now, not at the next poll
    return BuildLoads({row}, {response});
}

absl::Status SoilVolumeHandlers::GetLoad(const v1::GetLoadRequest& request, v1::Load* response,
                                         CallRecord& record) {
    record.ids.push_back({"load", request.load_id()});
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.load_id(), "load_id"));
    const absl::StatusOr<LoadRecord> row = store->GetLoad(request.load_id());
    if (!row.ok()) return Annotate(row.status(), "load_id");
    return BuildLoads({*row}, {response});
}

absl::Status SoilVolumeHandlers::ListLoads(const v1::ListLoadsRequest& request,
                                           v1::ListLoadsResponse* response, CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    LoadQuery query;
    if (!request.haul_unit_id().empty()) {
        SOILVOL_RETURN_IF_ERROR(ValidateRequestId(request.haul_unit_id(), "haul_unit_id"));
        query.haul_unit_id = request.haul_unit_id();
    }
    if (request.state() == v1::LOAD_STATE_OPEN) query.state = LoadRecord::kOpen;
    if (request.state() == v1::LOAD_STATE_CLOSED) query.state = LoadRecord::kClosed;
    if (options_.load_idle_us > 0) query.open_since_us = NowMicros() - options_.load_idle_us;
    SOILVOL_ASSIGN_OR_RETURN(const int size, PageSizeOf(request.page_size()));
    SOILVOL_ASSIGN_OR_RETURN(query.before_seq, ParseRecordPageToken(request.page_token()));
    query.limit = size + 1;  // one more tells whether there is a next page
    SOILVOL_ASSIGN_OR_RETURN(std::vector<LoadRecord> rows, store->ListLoads(query));
    const bool more = rows.size() > static_cast<std::size_t>(size);
    if (more) rows.resize(static_cast<std::size_t>(size));
    std::vector<v1::Load*> outs;
    for (std::size_t i = 0; i < rows.size(); ++i) outs.push_back(response->add_loads());
    SOILVOL_RETURN_IF_ERROR(BuildLoads(rows, outs));
    if (more && !rows.empty()) response->set_next_page_token(RecordPageToken(rows.back().seq));
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::CloseLoad(const v1::CloseLoadRequest& request, v1::Load* response,
                                           CallRecord& record) {
    record.ids.push_back({"load", request.load_id()});
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.load_id(), "load_id"));
    std::optional<std::int64_t> revision;
    if (!request.etag().empty()) {
        // Not one this server made: matches no load (ABORTED, as any stale etag).
        std::int64_t parsed = -1;
        revision = absl::SimpleAtoi(request.etag(), &parsed) ? parsed : -1;
    }
    const absl::StatusOr<LoadRecord> row =
        store->CloseLoad(request.load_id(), NowMicros(), options_.load_idle_us, revision);
    if (absl::IsNotFound(row.status())) return Annotate(row.status(), "load_id");
    SOILVOL_RETURN_IF_ERROR(row.status());
    JudgeClosed();
    recorder_->WakeWaiters();
    return BuildLoads({*row}, {response});
}

absl::StatusOr<std::optional<LoadLink>> SoilVolumeHandlers::LoadLinkOf(
    const v1::EstimateVolumeRequest& request, v1::EstimateVolumeResponse* response) const {
    if (request.load_id().empty()) return std::optional<LoadLink>();
    if (!Records(request)) {
        return absl::FailedPreconditionError(
            "load_id: a load's passes are its records: not with skip_record, nor with records off");
    }
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.load_id(), "load_id"));
    const absl::StatusOr<LoadRecord> row = recorder_->store().GetLoad(request.load_id());
    if (!row.ok()) return Annotate(row.status(), "load_id");
    LoadLink link{request.load_id(), LoadLink::kPass, options_.load_idle_us};
    if (request.container_id() == row->body_container_id) link.role = LoadLink::kBodyScan;
    LoadRecord now = *row;
    ApplyIdleClose(now, NowMicros(), link.idle_us);
    SOILVOL_RETURN_IF_ERROR(CheckJoin(now, link));  // before the work; the commit checks again
    response->set_load_id(link.load_id);
    response->set_load_role(link.role == LoadLink::kPass ? v1::LOAD_ROLE_PASS
                                                         : v1::LOAD_ROLE_BODY_SCAN);
    return std::optional<LoadLink>(std::move(link));
}

}  // namespace soilvol::server
