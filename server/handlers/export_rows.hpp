#pragma once

#include <functional>
#include <string>

#include "absl/status/statusor.h"
#include "google/protobuf/message.h"
#include "server/handlers/rpc_table.hpp"

namespace soilvol::server {

/// How an export writes its rows.
enum class ExportFormat {
    kCsv,        ///< RFC 4180: a header line, then one line per item (text/csv)
    kJsonLines,  ///< one proto3 JSON object per line (application/x-ndjson)
};

/// "csv" or "jsonl" (also "ndjson"); InvalidArgument naming `format` otherwise.
absl::StatusOr<ExportFormat> ParseExportFormat(const std::string& text);

/// The CSV header line (with its CRLF) of the items a list returns: Estimate, Load or
/// ProductionRow; Internal for another message.
absl::StatusOr<std::string> CsvHeader(const google::protobuf::Descriptor& item);
/// One item as a CSV line with its CRLF: numbers as they are, text quoted when it holds a
/// comma, quote or line break, and text a spreadsheet would run as a formula (starting with
/// = + - @ or a tab) led by a single quote.
std::string CsvLine(const google::protobuf::Message& item);

/// Writes every item `list` (a List RPC: ListEstimates, ListLoads or GetProduction) returns
/// for `request` (its filters; its page size and token are the export's), page after page of
/// 1000, to `write` in chunks of about 64 KiB: memory stays flat whatever the count. Stops
/// with Cancelled when `write` returns false (the client left) or `record.stop` asks.
absl::Status ExportList(const Rpc& list, google::protobuf::Message& request, ExportFormat format,
                        CallRecord& record, const std::function<bool(std::string)>& write);

}  // namespace soilvol::server
