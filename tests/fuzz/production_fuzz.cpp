// libFuzzer: what a production request names (server/records/production) on any bytes: the
// zone's name (line 1), the shift starts (line 2, comma-separated) and a range (the rest, its
// first 8 bytes a start in this century, the next one a span of up to 40 days). A zone it
// loads stays in the zone database; periods made from what it accepts are contiguous,
// increasing, labelled and no more than asked for.
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "absl/strings/str_split.h"
#include "server/records/production.hpp"

namespace {

std::int64_t Bytes(const std::string& text, std::size_t at, std::size_t n) {
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < n && at + i < text.size(); ++i) {
        value = (value << 8) | static_cast<unsigned char>(text[at + i]);
    }
    return static_cast<std::int64_t>(value & 0x7fffffffffffffffULL);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace soilvol::server;
    const std::string text(reinterpret_cast<const char*>(data), size);
    const std::vector<std::string> lines = absl::StrSplit(text, absl::MaxSplits('\n', 2));
    const auto zone = LoadSiteZone(lines[0], "time_zone");
    if (zone.ok() && (lines[0].find("..") != std::string::npos || lines[0][0] == '/')) {
        std::abort();
    }
    if (lines.size() < 2) return 0;
    const auto starts = ParseShiftStarts(absl::StrSplit(lines[1], ','), "shift_starts");
    if (starts.ok()) {
        for (std::size_t i = 0; i < starts->size(); ++i) {
            const int m = (*starts)[i];
            if (m < 0 || m >= 1440 || m % 15 != 0 || (i > 0 && m <= (*starts)[i - 1])) std::abort();
        }
    }
    if (!zone.ok() || !starts.ok() || lines.size() < 3) return 0;
    constexpr std::int64_t k2000 = 946684800LL * 1'000'000, kCentury = 3155760000LL * 1'000'000;
    const std::int64_t start = k2000 + Bytes(lines[2], 0, 8) % kCentury;
    const std::int64_t end = start + 1 + Bytes(lines[2], 8, 4) % (40LL * 86400 * 1'000'000);
    const SiteCalendar calendar{*zone, *starts};
    for (const ProductionPeriod period :
         {ProductionPeriod::kHour, ProductionPeriod::kShift, ProductionPeriod::kDay}) {
        const auto periods = MakePeriods(calendar, period, start, end, 5000);
        if (!periods.ok()) continue;
        if (periods->empty() || periods->size() > 5000) std::abort();
        if (periods->front().start_us > start || periods->back().end_us < end) std::abort();
        for (std::size_t i = 0; i < periods->size(); ++i) {
            const Period& p = (*periods)[i];
            if (p.end_us <= p.start_us || p.label.empty()) std::abort();
            if (i > 0 && p.start_us != (*periods)[i - 1].end_us) std::abort();
        }
    }
    return 0;
}
