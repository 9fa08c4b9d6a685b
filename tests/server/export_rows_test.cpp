#include "server/handlers/export_rows.hpp"

#include <gtest/gtest.h>

#include "absl/strings/str_split.h"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {
namespace {

/// Splits a CSV line at its commas outside quotes (what a reader does), CRLF dropped.
std::vector<std::string> Cells(const std::string& line) {
    std::vector<std::string> cells(1);
    bool quoted = false;
    for (std::size_t i = 0; i + 2 <= line.size(); ++i) {
        const char c = line[i];
        if (i + 2 == line.size() && line.substr(i) == "\r\n") break;
        if (c == '"') {
            if (quoted && i + 1 < line.size() && line[i + 1] == '"') {
                cells.back() += '"';
                ++i;
            } else {
                quoted = !quoted;
            }
        } else if (c == ',' && !quoted) {
            cells.emplace_back();
        } else {
            cells.back() += c;
        }
    }
    return cells;
}

TEST(ExportRows, FormatsByName) {
    EXPECT_EQ(*ParseExportFormat("csv"), ExportFormat::kCsv);
    EXPECT_EQ(*ParseExportFormat("jsonl"), ExportFormat::kJsonLines);
    EXPECT_EQ(*ParseExportFormat("ndjson"), ExportFormat::kJsonLines);
    const auto bad = ParseExportFormat("xlsx");
    EXPECT_TRUE(absl::IsInvalidArgument(bad.status()));
    EXPECT_EQ(std::string(bad.status().message()).rfind("format: ", 0), 0u);
}

TEST(ExportRows, EveryLineHasTheHeadersColumns) {
    v1::Estimate estimate;
    estimate.set_estimate_id("7");
    estimate.mutable_result()->set_volume_m3(1.25);
    v1::Load load;
    load.set_load_id("l-1");
    load.mutable_reconciliation()->set_within_two_sigma(true);
    v1::ProductionRow row;
    row.set_passes(3);
    (*row.mutable_status_counts())["loaded_ok"] = 2;
    for (const google::protobuf::Message* item :
         std::vector<const google::protobuf::Message*>{&estimate, &load, &row}) {
        const auto header = CsvHeader(*item->GetDescriptor());
        ASSERT_TRUE(header.ok()) << header.status();
        EXPECT_EQ(Cells(*header).size(), Cells(CsvLine(*item)).size()) << *header;
        EXPECT_EQ(CsvLine(*item).substr(CsvLine(*item).size() - 2), "\r\n");
    }
    EXPECT_EQ(Cells(CsvLine(estimate))[7], "1.25");
    EXPECT_EQ(Cells(CsvLine(row)).back(), "0");  // status_loaded
    EXPECT_EQ(Cells(CsvLine(row))[14], "2");     // status_loaded_ok
    EXPECT_FALSE(CsvHeader(*v1::Container::descriptor()).ok());
}

TEST(ExportRows, TextIsQuotedAndFormulasDefused) {
    v1::Load load;
    load.set_haul_unit_id("=HYPERLINK(\"x\")");
    load.set_display_name("Truck 7, \"the red one\"\nnight shift");
    const std::vector<std::string> cells = Cells(CsvLine(load));
    EXPECT_EQ(cells[1], "'=HYPERLINK(\"x\")");
    EXPECT_EQ(cells[3], "Truck 7, \"the red one\"\nnight shift");
    v1::Estimate negative;
    negative.mutable_result()->set_volume_m3(-0.5);  // a number keeps its sign
    EXPECT_EQ(Cells(CsvLine(negative))[7], "-0.5");
}

/// A list of `total` loads served `page_size` at a time, as ListLoads pages.
Rpc FakeLoads(int total, int* calls) {
    Rpc rpc;
    rpc.new_request = [] { return std::make_unique<v1::ListLoadsRequest>(); };
    rpc.new_response = [] { return std::make_unique<v1::ListLoadsResponse>(); };
    rpc.call = [total, calls](const google::protobuf::Message& in, google::protobuf::Message* out,
                              CallRecord&) {
        ++*calls;
        const auto& request = dynamic_cast<const v1::ListLoadsRequest&>(in);
        auto& response = dynamic_cast<v1::ListLoadsResponse&>(*out);
        const int first = request.page_token().empty() ? 0 : std::stoi(request.page_token());
        const int last = std::min(total, first + request.page_size());
        for (int i = first; i < last; ++i) {
            response.add_loads()->set_load_id("load-" + std::to_string(i));
        }
        if (last < total) response.set_next_page_token(std::to_string(last));
        return absl::OkStatus();
    };
    return rpc;
}

TEST(ExportRows, PagesThroughTheListInBoundedChunks) {
    int calls = 0;
    const Rpc rpc = FakeLoads(2500, &calls);
    v1::ListLoadsRequest request;
    request.set_haul_unit_id("truck-7");
    CallRecord record;
    std::string all;
    std::size_t largest = 0;
    const absl::Status done =
        ExportList(rpc, request, ExportFormat::kJsonLines, record, [&](std::string chunk) {
            largest = std::max(largest, chunk.size());
            all += chunk;
            return true;
        });
    ASSERT_TRUE(done.ok()) << done;
    EXPECT_EQ(calls, 3);  // 1000 a page
    const std::vector<std::string> lines = absl::StrSplit(all, '\n', absl::SkipEmpty());
    ASSERT_EQ(lines.size(), 2500u);
    EXPECT_EQ(lines[2499], "{\"loadId\":\"load-2499\"}");
    EXPECT_LT(largest, 80u * 1024);                // chunks of about 64 KiB
    EXPECT_EQ(request.haul_unit_id(), "truck-7");  // the filters stay
}

TEST(ExportRows, ALeavingClientStopsTheExport) {
    int calls = 0;
    const Rpc rpc = FakeLoads(100000, &calls);
    v1::ListLoadsRequest request;
    CallRecord record;
    int chunks = 0;
    const absl::Status done = ExportList(rpc, request, ExportFormat::kCsv, record,
                                         [&](std::string) { return ++chunks < 2; });
    EXPECT_TRUE(absl::IsCancelled(done)) << done;
    EXPECT_EQ(chunks, 2);
    EXPECT_LT(calls, 10);
}

}  // namespace
}  // namespace soilvol::server
