#pragma once

/// Every unary RPC of soilvol.v1.SoilVolume as X(name, request, response) (messages in
/// soilvol::v1): the one list the RPC table (MakeRpcTable, which REST and gRPC both call
/// through) and the gRPC service's methods are made from. CheckRpcTable refuses to start a
/// server whose list misses an RPC of the proto or names other messages.
#define SOILVOL_UNARY_RPCS(X)                                                             \
    X(Calibrate, CalibrateRequest, Calibration)                                           \
    X(GetCalibration, GetCalibrationRequest, Calibration)                                 \
    X(ListCalibrations, ListCalibrationsRequest, ListCalibrationsResponse)                \
    X(DeleteCalibration, DeleteCalibrationRequest, DeleteCalibrationResponse)             \
    X(RegisterContainer, RegisterContainerRequest, Container)                             \
    X(GetContainer, GetContainerRequest, Container)                                       \
    X(ListContainers, ListContainersRequest, ListContainersResponse)                      \
    X(UpdateContainer, UpdateContainerRequest, Container)                                 \
    X(GetEstimate, GetEstimateRequest, Estimate)                                          \
    X(ListEstimates, ListEstimatesRequest, ListEstimatesResponse)                         \
    X(DeleteContainer, DeleteContainerRequest, DeleteContainerResponse)                   \
    X(EstimateVolume, EstimateVolumeRequest, EstimateVolumeResponse)                      \
    X(CreateLoad, CreateLoadRequest, Load)                                                \
    X(GetLoad, GetLoadRequest, Load)                                                      \
    X(ListLoads, ListLoadsRequest, ListLoadsResponse)                                     \
    X(CloseLoad, CloseLoadRequest, Load)                                                  \
    X(GetProduction, GetProductionRequest, Production)                                    \
    X(ListAlerts, ListAlertsRequest, ListAlertsResponse)                                  \
    X(ListWebhooks, ListWebhooksRequest, ListWebhooksResponse)                            \
    X(ListWebhookDeliveries, ListWebhookDeliveriesRequest, ListWebhookDeliveriesResponse) \
    X(GetServerInfo, GetServerInfoRequest, ServerInfo)
