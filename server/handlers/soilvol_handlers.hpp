#pragma once

#include <array>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/depth/depth_scan.hpp"
#include "core/io/mesh_codec.hpp"
#include "core/model/container_model.hpp"
#include "core/pipeline/estimator.hpp"
#include "core/pipeline/registration.hpp"
#include "core/stereo/reconstructor.hpp"
#include "core/volume/load_totals.hpp"
#include "server/handlers/call_record.hpp"
#include "server/records/record_feed.hpp"
#include "server/records/recorder.hpp"
#include "server/store/entry_cache.hpp"
#include "server/store/entry_store.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// What the handlers take from the server's options.
/// The store's precondition of a write or delete at `etag`: the entry published at the moment
/// of the write must still carry it (ABORTED otherwise, NOT_FOUND when it is gone), errors
/// annotated with `field`.
EntryStore::Precondition EtagIs(EntryKind kind, const std::string& id, const std::string& etag,
                                const char* field);

struct HandlerOptions {
    /// A registration whose struck capacity's 1-sigma exceeds this share of it warns
    /// (Container.warnings), (0, 1].
    double capacity_warning_share = 0.01;
    /// What one registration's mesh may hold (MeshBudgetFor the largest message).
    io::MeshBudget mesh_budget;
    /// An open load with no pass for this long is closed (--load-idle-seconds); 0: never.
    std::int64_t load_idle_us = 30LL * 60 * 1'000'000;
    /// Production's default zone and shift starts (--site-time-zone, --shift-starts).
    std::string site_time_zone = "UTC";
    std::vector<std::string> shift_starts = {"06:00", "18:00"};
    /// The alerts of containers without their own rules, and of loads (--alert-rules).
    v1::AlertRules alert_rules;
    /// The configured webhooks (--webhooks-file), for ListWebhooks.
    std::vector<v1::Webhook> webhooks;
};

/// The RPCs of soilvol.v1.SoilVolume over proto messages, free of any transport: the gRPC
/// service and the REST gateway both call these (on a worker of the pool). Each converts the
/// request to core types, runs the engine, stores or loads entries and fills the response;
/// errors are absl statuses whose messages name the request field at fault.
class SoilVolumeHandlers {
  public:
    /// `recorder` keeps estimate records, `feed` serves their watches, `alert_feed` the
    /// alerts' and `load_feed` the load events'; null: records are off (estimates are not kept;
    /// the records' RPCs fail with FAILED_PRECONDITION).
    SoilVolumeHandlers(EntryStore& store, EstimateRecorder* recorder, EstimateFeed* feed,
                       AlertFeed* alert_feed, LoadEventFeed* load_feed,
                       HandlerOptions options = {});

    absl::Status Calibrate(const v1::CalibrateRequest& request, v1::Calibration* response,
                           CallRecord& record);
    absl::Status GetCalibration(const v1::GetCalibrationRequest& request, v1::Calibration* response,
                                CallRecord& record);
    absl::Status ListCalibrations(const v1::ListCalibrationsRequest& request,
                                  v1::ListCalibrationsResponse* response, CallRecord& record);
    absl::Status DeleteCalibration(const v1::DeleteCalibrationRequest& request,
                                   v1::DeleteCalibrationResponse* response, CallRecord& record);

    absl::Status RegisterContainer(const v1::RegisterContainerRequest& request,
                                   v1::Container* response, CallRecord& record);
    absl::Status GetContainer(const v1::GetContainerRequest& request, v1::Container* response,
                              CallRecord& record);
    absl::Status ListContainers(const v1::ListContainersRequest& request,
                                v1::ListContainersResponse* response, CallRecord& record);
    absl::Status UpdateContainer(const v1::UpdateContainerRequest& request, v1::Container* response,
                                 CallRecord& record);
    absl::Status DeleteContainer(const v1::DeleteContainerRequest& request,
                                 v1::DeleteContainerResponse* response, CallRecord& record);

    absl::Status EstimateVolume(const v1::EstimateVolumeRequest& request,
                                v1::EstimateVolumeResponse* response, CallRecord& record);

    absl::Status GetEstimate(const v1::GetEstimateRequest& request, v1::Estimate* response,
                             CallRecord& record);
    absl::Status ListEstimates(const v1::ListEstimatesRequest& request,
                               v1::ListEstimatesResponse* response, CallRecord& record);

    absl::Status CreateLoad(const v1::CreateLoadRequest& request, v1::Load* response,
                            CallRecord& record);
    absl::Status GetLoad(const v1::GetLoadRequest& request, v1::Load* response, CallRecord& record);
    absl::Status ListLoads(const v1::ListLoadsRequest& request, v1::ListLoadsResponse* response,
                           CallRecord& record);
    absl::Status CloseLoad(const v1::CloseLoadRequest& request, v1::Load* response,
                           CallRecord& record);
    /// WatchLoads, as WatchEstimates: each event with its load as it stood then.
    using LoadEventDeliver = std::function<bool(const v1::LoadEvent*)>;
    absl::StatusOr<std::function<void()>> WatchLoads(
        const v1::WatchLoadsRequest& request, LoadEventDeliver deliver,
        std::function<void(const absl::Status&)> ended);

    absl::Status GetProduction(const v1::GetProductionRequest& request, v1::Production* response,
                               CallRecord& record);

    /// WatchEstimates, free of any transport: `deliver` gets each record as the API message
    /// (null for a heartbeat; false ends the watch), `ended` why the server ended it. The
    /// returned function stops the watch (the client left); after it returns neither callback
    /// runs again.
    using WatchDeliver = std::function<bool(const v1::Estimate*)>;
    using WatchEnded = std::function<void(const absl::Status&)>;
    absl::StatusOr<std::function<void()>> WatchEstimates(const v1::WatchEstimatesRequest& request,
                                                         WatchDeliver deliver, WatchEnded ended);

    absl::Status ListAlerts(const v1::ListAlertsRequest& request, v1::ListAlertsResponse* response,
                            CallRecord& record);
    /// WatchAlerts, as WatchEstimates.
    using AlertDeliver = std::function<bool(const v1::Alert*)>;
    absl::StatusOr<std::function<void()>> WatchAlerts(const v1::WatchAlertsRequest& request,
                                                      AlertDeliver deliver, WatchEnded ended);
    absl::Status ListWebhooks(const v1::ListWebhooksRequest& request,
                              v1::ListWebhooksResponse* response, CallRecord& record);
    absl::Status ListWebhookDeliveries(const v1::ListWebhookDeliveriesRequest& request,
                                       v1::ListWebhookDeliveriesResponse* response,
                                       CallRecord& record);
    /// Judges every load whose close was not judged (closing idle ones first): each raises
    /// LOAD_OFF_TARGET under its rules, once across replicas. CloseLoad and CreateLoad call it;
    /// the server's sweeper every second. How many this call judged.
    absl::StatusOr<int> JudgeLoads(std::int64_t now_us);
    /// What this server's judge decided since the start: loads closed by status (LoadStatus
    /// numbers), LOAD_OFF_TARGET alerts raised (for /metrics).
    struct JudgeFigures {
        std::array<std::uint64_t, 7> loads_closed{};
        std::uint64_t load_alerts = 0;
    };
    JudgeFigures judge_figures() const;
    absl::Status GetServerInfo(const v1::GetServerInfoRequest& request, v1::ServerInfo* response,
                               CallRecord& record);

    /// Readiness: the data directory takes writes.
    absl::Status CheckReady() const { return store_.CheckWritable(); }

  private:
    struct CalibrationEntry {
        v1::Calibration info;
        std::shared_ptr<const stereo::StereoReconstructor> stereo;
    };
    struct ContainerEntry {
        v1::Container info;
        model::ContainerModel model;
    };
    /// A decoded scan: a cloud, or a stereo pair with its calibration.
    struct Scan {
        Cloud cloud;
        std::size_t dropped_nonfinite = 0;
        double decode_ms = 0.0;                               ///< cloud scans: parsing the file
        std::shared_ptr<const CalibrationEntry> calibration;  ///< set for stereo scans
        std::optional<depth::DepthScanCounts> depth_counts;   ///< set for depth scans
        std::size_t depth_points = 0;
        std::vector<SensorCloud> more_sensors;  ///< the scan's other sensors (cloud or depth)
        std::string_view left, right;
    };

    absl::StatusOr<std::shared_ptr<const CalibrationEntry>> LoadCalibration(
        const std::string& id, const std::string& field) const;
    absl::StatusOr<std::shared_ptr<const ContainerEntry>> LoadContainer(
        const std::string& id, const std::string& field) const;
    /// `calibration_id` stands in for an empty scan.stereo.calibration_id.
    absl::StatusOr<Scan> DecodeScan(const v1::Scan& scan, const std::string& calibration_id,
                                    CallRecord& record) const;
    /// The estimate of a decoded scan (cloud or stereo), with the decode and stereo timings.
    absl::StatusOr<pipeline::VolumeEstimate> RunEstimate(const ContainerEntry& container,
                                                         const Scan& scan,
                                                         const pipeline::EstimateConfig& config,
                                                         v1::Timings* timings,
                                                         const StopToken& stop) const;
    /// The model of a registration: from its mesh (BuildMeshModel), or from its first scan
    /// (stereo, or cloud with the request's additional scans fused); sets registered_from and
    /// calibration_id in `response`.
    absl::StatusOr<model::ContainerModel> BuildModel(const v1::RegisterContainerRequest& request,
                                                     const model::ModelConfig& config,
                                                     v1::Container* response,
                                                     CallRecord& record) const;
    /// The model of a registration with a mesh: with the request's point-cloud scans, or the
    /// mesh alone at its pose (pipeline::RegisterWithMesh).
    absl::StatusOr<model::ContainerModel> BuildMeshModel(
        const v1::RegisterContainerRequest& request, const model::ModelConfig& config,
        v1::Container* response, CallRecord& record) const;
    /// `container` as it leaves the server: its warnings computed anew from its figures with
    /// the configured share (pipeline::CapacityWarnings).
    void AddWarnings(v1::Container* container) const;
    /// `first` and the request's additional_scans, decoded (at most max_scans in all).
    absl::StatusOr<std::vector<pipeline::EmptyScan>> DecodeEmptyScans(
        const v1::RegisterContainerRequest& request, const Scan& first, std::size_t max_scans,
        CallRecord& record) const;
    /// What a create asks of its entry's id (AIP-133, AIP-155 request_id, AIP-154 etag).
    struct Create {
        EntryKind kind;
        const std::string& id;
        const char* id_field;
        bool overwrite;
        const std::string& etag;
        const std::string& request_id;
    };
    /// The id `create` writes: the request's, or one the server picks (derived from the
    /// request_id when there is one). When the entry exists and was made by a request with the
    /// same request_id, sets `replayed` and leaves that entry's info in `stored`: the retry gets
    /// the first result. Otherwise AlreadyExists when taken and not overwrite, Aborted when
    /// overwrite names a stale etag, InvalidArgument for an etag without overwrite.
    absl::StatusOr<std::string> ClaimId(const Create& create, google::protobuf::Message* stored,
                                        bool* replayed) const;
    /// Writes `info` (given its create_request_id and a new etag) and `body` under `id`. A
    /// concurrent retry of the same request that wrote first makes `info` its entry's.
    absl::Status Store(const Create& create, const std::string& id, google::protobuf::Message* info,
                       std::string_view body);
    /// The stored info of an entry (NotFound when absent).
    absl::Status ReadInfo(EntryKind kind, const std::string& id,
                          google::protobuf::Message* info) const;
    /// Deletes an entry, only at `etag` when one is given.
    absl::Status DeleteEntry(EntryKind kind, const std::string& id, const char* field,
                             const std::string& etag);

    /// Whether EstimateVolume keeps a record of this request's estimate.
    bool Records(const v1::EstimateVolumeRequest& request) const {
        return recorder_ != nullptr && !request.skip_record();
    }
    /// Keeps the record of an answered estimate (the response as it is now, heightmap
    /// included) when Records(request): the call is answered, with the record's id, once the
    /// record is committed (CallRecord::finish_later; the worker does not wait for it).
    void RecordEstimate(const v1::EstimateVolumeRequest& request,
                        v1::EstimateVolumeResponse* response, std::optional<LoadLink> load,
                        Measures measures, CallRecord& record);
    /// JudgeLoads now, its failure logged (the sweeper tries again).
    void JudgeClosed();
    /// A refused estimate (FAILED_PRECONDITION from the engine) counted in its container's run
    /// of refusals (REFUSED_SCANS), when the request keeps records.
    void CountRefusal(const v1::EstimateVolumeRequest& request, const v1::Container& container,
                      const absl::Status& refused);
    /// The registration ListEstimates shows (RecordQuery::registration_id; "" = every one).
    absl::StatusOr<std::string> RegistrationFilter(const v1::ListEstimatesRequest& request);
    /// The recorder, or FailedPrecondition when records are off.
    absl::StatusOr<EstimateRecorder*> Recorder() const;
    /// The records' store, which keeps the loads, or FailedPrecondition when records are off.
    absl::StatusOr<RecordStore*> LoadStore() const;
    /// What an EstimateVolume naming a load is to it (none without load_id), checked before
    /// the work: NotFound for no such load, FailedPrecondition for a pass to a closed load or
    /// without a record. Sets the response's load_id and load_role.
    absl::StatusOr<std::optional<LoadLink>> LoadLinkOf(const v1::EstimateVolumeRequest& request,
                                                       v1::EstimateVolumeResponse* response) const;
    /// The API message of each load in `rows` into outs[i], its figures from its records.
    absl::Status BuildLoads(const std::vector<LoadRecord>& rows, std::vector<v1::Load*> outs) const;
    /// The API message of `row` (as it stands at now_us) from `records`, its passes and body
    /// scans oldest first.
    absl::Status BuildLoad(const LoadRecord& row, const std::vector<const EstimateRecord*>& records,
                           std::int64_t now_us, v1::Load* out) const;
    /// The API message of a load event, its load built from the event's records.
    absl::Status BuildLoadEvent(const LoadEventRecord& row, v1::LoadEvent* out) const;
    /// The request's zone and shift starts (or the server's), echoed into `response`.
    absl::StatusOr<SiteCalendar> CalendarOf(const v1::GetProductionRequest& request,
                                            v1::Production* response) const;
    /// The group of a production cell under the request's grouping.
    std::function<std::string(const ProductionCell&)> GroupOf(
        const v1::GetProductionRequest& request) const;
    /// The assessment of `totals` against the load's targets, or its body container's.
    void AssessTotals(const volume::LoadTotals& totals, v1::Load* out) const;

    static absl::StatusOr<CalibrationEntry> DecodeCalibration(const StoredEntry& entry);
    static absl::StatusOr<ContainerEntry> DecodeContainer(const StoredEntry& entry);

    EntryStore& store_;
    const HandlerOptions options_;
    EstimateRecorder* const recorder_;
    EstimateFeed* const feed_;
    AlertFeed* const alert_feed_;
    LoadEventFeed* const load_feed_;
    mutable std::mutex judge_mutex_;
    JudgeFigures judged_;
    const google::protobuf::Timestamp start_time_;
    mutable EntryCache<CalibrationEntry> calibrations_;
    mutable EntryCache<ContainerEntry> containers_;
};

}  // namespace soilvol::server
