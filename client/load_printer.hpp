#pragma once

#include <ostream>

#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// A truck load in full (fields, then its passes); with `json` one proto3 JSON document.
void PrintLoad(const v1::Load& load, bool json, std::ostream& out);
/// One load event as a line (id, time, kind, load, haul unit, state, passes, volume); with
/// `json` one proto3 JSON line.
void PrintLoadEventLine(const v1::LoadEvent& event, bool json, std::ostream& out);
/// Loads as a table, newest first.
void PrintLoadList(const v1::ListLoadsResponse& list, bool json, std::ostream& out);

}  // namespace soilvol::client
