#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/model/container_model.hpp"
#include "core/pipeline/registration.hpp"
#include "core/stereo/reconstructor.hpp"
#include "server/dispatcher.hpp"
#include "server/store/entry_cache.hpp"
#include "server/store/entry_store.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// The RPCs of soilvol.v1.SoilVolume over proto messages, free of any transport: the gRPC
/// service and the REST gateway both call these (on a worker of the pool). Each converts the
/// request to core types, runs the engine, stores or loads entries and fills the response;
/// errors are absl statuses whose messages name the request field at fault.
class SoilVolumeHandlers {
  public:
    explicit SoilVolumeHandlers(EntryStore& store);

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
    absl::Status DeleteContainer(const v1::DeleteContainerRequest& request,
                                 v1::DeleteContainerResponse* response, CallRecord& record);

    absl::Status EstimateVolume(const v1::EstimateVolumeRequest& request,
                                v1::EstimateVolumeResponse* response, CallRecord& record);

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
        std::string_view left, right;
    };

    absl::StatusOr<std::shared_ptr<const CalibrationEntry>> LoadCalibration(
        const std::string& id, const std::string& field) const;
    absl::StatusOr<std::shared_ptr<const ContainerEntry>> LoadContainer(
        const std::string& id, const std::string& field) const;
    /// `calibration_id` stands in for an empty scan.stereo.calibration_id.
    absl::StatusOr<Scan> DecodeScan(const v1::Scan& scan, const std::string& calibration_id,
                                    CallRecord& record) const;
    /// `first` and the request's additional_scans, decoded (at most max_scans in all).
    absl::StatusOr<std::vector<pipeline::EmptyScan>> DecodeEmptyScans(
        const v1::RegisterContainerRequest& request, const Cloud& first, std::size_t max_scans,
        CallRecord& record) const;
    /// The request's id, or a new one when it is empty; AlreadyExists when taken and
    /// `overwrite` is false (checked again atomically when the entry is written).
    absl::StatusOr<std::string> ClaimId(EntryKind kind, const std::string& id,
                                        const std::string& field, bool overwrite) const;

    static absl::StatusOr<CalibrationEntry> DecodeCalibration(const StoredEntry& entry);
    static absl::StatusOr<ContainerEntry> DecodeContainer(const StoredEntry& entry);

    EntryStore& store_;
    mutable EntryCache<CalibrationEntry> calibrations_;
    mutable EntryCache<ContainerEntry> containers_;
};

}  // namespace soilvol::server
