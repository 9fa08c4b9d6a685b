#pragma once

#include <cstdint>
#include <string>

#include "server/records/load_record.hpp"
#include "server/records/record_store.hpp"

namespace soilvol::server {

/// An open load of `haul_unit` created at `time_us`, its body "body", its payload with a NUL.
inline LoadRecord NewLoad(const std::string& id, const std::string& haul_unit,
                          std::int64_t time_us) {
    LoadRecord load;
    load.load_id = id;
    load.haul_unit_id = haul_unit;
    load.body_container_id = "body";
    load.create_time_us = load.update_time_us = load.last_activity_us = time_us;
    load.request_id = "req-" + id;
    load.payload = std::string("client\0fields", 13);
    return load;
}

/// A record joining `load_id` (a pass of "bucket" or a body scan of "body" unless
/// `container_id` says).
inline EstimateRecord Pass(const std::string& load_id, std::int64_t time_us,
                           int role = LoadLink::kPass, std::int64_t idle_us = 0,
                           std::string container_id = "") {
    EstimateRecord record;
    record.container_id = !container_id.empty()     ? std::move(container_id)
                          : role == LoadLink::kPass ? "bucket"
                                                    : "body";
    record.create_time_us = time_us;
    record.payload = "p";
    record.load = LoadLink{load_id, role, idle_us};
    return record;
}

}  // namespace soilvol::server
