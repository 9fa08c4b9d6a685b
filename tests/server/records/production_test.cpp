#include "server/records/production.hpp"

#include <gtest/gtest.h>

namespace soilvol::server {
namespace {

constexpr std::int64_t kHourUs = 3600LL * 1'000'000;

absl::TimeZone Zone(const char* name) {
    absl::TimeZone zone;
    EXPECT_TRUE(absl::LoadTimeZone(name, &zone)) << name << ": is tzdata installed?";
    return zone;
}

std::int64_t At(const char* rfc3339) {
    absl::Time t;
    std::string error;
    EXPECT_TRUE(absl::ParseTime(absl::RFC3339_full, rfc3339, &t, &error)) << error;
    return absl::ToUnixMicros(t);
}

TEST(Production, BucketsAreQuarterHoursFlooredAlsoBefore1970) {
    EXPECT_EQ(ProductionBucketOf(At("2026-12-07T06:14:59Z")), At("2026-12-07T06:00:00Z"));
    EXPECT_EQ(ProductionBucketOf(At("2026-12-07T06:15:00Z")), At("2026-12-07T06:15:00Z"));
    EXPECT_EQ(ProductionBucketOf(-1), -kProductionBucketUs);
}

TEST(Production, ShiftStartsAreQuarterHoursSortedAndUnique) {
    const auto starts = ParseShiftStarts({"18:00", "06:00", "22:45"}, "shift_starts");
    ASSERT_TRUE(starts.ok()) << starts.status();
    EXPECT_EQ(*starts, (std::vector<int>{360, 1080, 1365}));
    for (const auto& bad : std::vector<std::vector<std::string>>{
             {}, {"6:00"}, {"06:10"}, {"24:00"}, {"06:00", "06:00"}, {"06:00x"}, {"aa:bb"}}) {
        const auto parsed = ParseShiftStarts(bad, "shift_starts");
        EXPECT_TRUE(absl::IsInvalidArgument(parsed.status())) << testing::PrintToString(bad);
        EXPECT_EQ(std::string(parsed.status().message()).rfind("shift_starts: ", 0), 0u);
    }
}

TEST(Production, ZoneNamesStayInTheZoneDatabase) {
    EXPECT_TRUE(LoadSiteZone("Europe/Berlin", "time_zone").ok());
    EXPECT_TRUE(LoadSiteZone("UTC", "time_zone").ok());
    EXPECT_TRUE(LoadSiteZone("America/Argentina/Buenos_Aires", "time_zone").ok());
    for (const char* bad :
         {"", "/etc/passwd", "../../../etc/passwd", "Europe/../../etc/passwd", "Europe//Berlin",
          "Europe/Berlin ", "Mars/Olympus", "Europe/Berlin\n", "/dev/stdin", "./UTC"}) {
        const auto zone = LoadSiteZone(bad, "time_zone");
        EXPECT_TRUE(absl::IsInvalidArgument(zone.status())) << bad;
        EXPECT_EQ(std::string(zone.status().message()).rfind("time_zone: ", 0), 0u) << bad;
    }
    EXPECT_FALSE(LoadSiteZone(std::string(65, 'A'), "time_zone").ok());
}

TEST(Production, DaysFollowTheZoneAcrossClockChanges) {
    const SiteCalendar berlin{Zone("Europe/Berlin"), {360}};
    const auto days = MakePeriods(berlin, ProductionPeriod::kDay, At("2026-03-28T12:00:00Z"),
                                  At("2026-03-30T12:00:00Z"), 100);
    ASSERT_TRUE(days.ok()) << days.status();
    ASSERT_EQ(days->size(), 3u);
    EXPECT_EQ((*days)[1].label, "2026-03-29");
    EXPECT_EQ((*days)[1].start_us, At("2026-03-28T23:00:00Z"));        // CET midnight
    EXPECT_EQ((*days)[1].end_us - (*days)[1].start_us, 23 * kHourUs);  // spring forward
    const auto autumn = MakePeriods(berlin, ProductionPeriod::kDay, At("2026-10-25T12:00:00Z"),
                                    At("2026-10-25T13:00:00Z"), 100);
    ASSERT_TRUE(autumn.ok());
    ASSERT_EQ(autumn->size(), 1u);
    EXPECT_EQ((*autumn)[0].end_us - (*autumn)[0].start_us, 25 * kHourUs);
}

TEST(Production, TheRepeatedHourOfAClockChangeBackIsAPeriodOfItsOwn) {
    const SiteCalendar berlin{Zone("Europe/Berlin"), {360}};
    const auto hours = MakePeriods(berlin, ProductionPeriod::kHour, At("2026-10-24T22:00:00Z"),
                                   At("2026-10-25T23:00:00Z"), 100);
    ASSERT_TRUE(hours.ok()) << hours.status();
    ASSERT_EQ(hours->size(), 25u);
    EXPECT_EQ((*hours)[2].label, "2026-10-25T02:00+02:00");
    EXPECT_EQ((*hours)[3].label, "2026-10-25T02:00+01:00");
    for (const Period& hour : *hours) EXPECT_EQ(hour.end_us - hour.start_us, kHourUs);
}

TEST(Production, HoursOfAQuarterHourZoneStartOnItsQuarter) {
    const SiteCalendar kathmandu{Zone("Asia/Kathmandu"), {360}};  // +05:45
    const auto hours = MakePeriods(kathmandu, ProductionPeriod::kHour, At("2026-12-07T00:20:00Z"),
                                   At("2026-12-07T01:20:00Z"), 100);
    ASSERT_TRUE(hours.ok());
    ASSERT_EQ(hours->size(), 2u);
    EXPECT_EQ((*hours)[0].start_us, At("2026-12-07T00:15:00Z"));
    EXPECT_EQ((*hours)[0].label, "2026-12-07T06:00+05:45");
}

TEST(Production, ShiftsRunToTheNextStartAcrossMidnightAndClockChanges) {
    const SiteCalendar site{Zone("Europe/Berlin"), {360, 1080}};  // 06:00 and 18:00
    const auto shifts = MakePeriods(site, ProductionPeriod::kShift, At("2026-10-24T05:00:00Z"),
                                    At("2026-10-25T16:00:00Z"), 100);
    ASSERT_TRUE(shifts.ok()) << shifts.status();
    ASSERT_EQ(shifts->size(), 3u);
    EXPECT_EQ((*shifts)[0].label, "2026-10-24 shift 1 (06:00)");
    EXPECT_EQ((*shifts)[1].label, "2026-10-24 shift 2 (18:00)");
    EXPECT_EQ((*shifts)[1].start_us, At("2026-10-24T16:00:00Z"));          // 18:00 CEST
    EXPECT_EQ((*shifts)[1].end_us - (*shifts)[1].start_us, 13 * kHourUs);  // the night gains one
    EXPECT_EQ((*shifts)[2].start_us, At("2026-10-25T05:00:00Z"));          // 06:00 CET
}

TEST(Production, TooManyPeriodsIsRefused) {
    const SiteCalendar utc{absl::UTCTimeZone(), {0}};
    const auto hours = MakePeriods(utc, ProductionPeriod::kHour, 0, 48 * kHourUs, 24);
    EXPECT_TRUE(absl::IsInvalidArgument(hours.status()));
    EXPECT_EQ(MakePeriods(utc, ProductionPeriod::kHour, 0, 24 * kHourUs, 24)->size(), 24u);
}

TEST(Production, CellsSumIntoTheirPeriodAndGroup) {
    const SiteCalendar utc{absl::UTCTimeZone(), {360, 1080}};
    const auto shifts = MakePeriods(utc, ProductionPeriod::kShift, At("2026-12-07T06:00:00Z"),
                                    At("2026-12-08T06:00:00Z"), 10);
    ASSERT_TRUE(shifts.ok());
    ASSERT_EQ(shifts->size(), 2u);
    auto cell = [](const char* time, const char* container, double volume, int status) {
        ProductionCell c;
        c.bucket_us = ProductionBucketOf(At(time));
        c.container_id = container;
        c.passes = 1;
        c.volume_m3 = volume;
        c.statuses[status] = 1;
        return c;
    };
    const std::vector<ProductionCell> cells = {
        cell("2026-12-07T05:45:00Z", "a", 100.0, 4),  // before the range
        cell("2026-12-07T06:00:00Z", "a", 1.0, 4),   cell("2026-12-07T17:45:00Z", "b", 2.0, 5),
        cell("2026-12-07T18:00:00Z", "a", 4.0, 4),   cell("2026-12-08T05:45:00Z", "a", 8.0, 3),
        cell("2026-12-08T06:00:00Z", "a", 100.0, 4)};  // after
    const auto rows =
        SumProduction(cells, *shifts, [](const ProductionCell& c) { return c.container_id; });
    ASSERT_EQ(rows.size(), 3u);
    EXPECT_EQ(rows[0].group, "a");
    EXPECT_EQ(rows[0].totals.volume_m3, 1.0);
    EXPECT_EQ(rows[1].group, "b");
    EXPECT_EQ(rows[1].totals.statuses[5], 1);
    EXPECT_EQ(rows[2].period, 1u);
    EXPECT_EQ(rows[2].totals.volume_m3, 12.0);
    EXPECT_EQ(rows[2].totals.passes, 2);
    EXPECT_EQ(rows[2].totals.statuses[3], 1);
}

}  // namespace
}  // namespace soilvol::server
