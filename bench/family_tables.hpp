#pragma once

#include <ostream>
#include <string>

namespace soilvol::bench {

/// Every container family (core/sim) with random dimensions, sensors (1-4 cm noise, 0.2-0.5 deg,
/// 0-2% outliers) and moves up to 5 deg / 10 cm, from empty to heaped; errors in % of struck
/// capacity and the share of estimates within 2 reported sigmas.
std::string FamilyTable(int seeds, std::ostream& kv);

/// The families scanned by one spinning lidar on a bridge and by two, one each side (markdown,
/// a part of FamilyTable's section); key=value lines to `kv`.
std::string SensorsTable(int seeds, std::ostream& kv);

/// Large container moves (up to 60 deg / 1 m) between the empty scan and a half-filled one,
/// estimated without an initial pose and with the true one (a machine's kinematics): how many
/// answers come back right (within 3% of struck), wrong, or refused.
std::string MovesTable(int seeds, std::ostream& kv);

struct FamilyCaseOptions {
    int family_index = 0;  ///< in sim::AllFamilies()
    int seed = 1;
    double fill_share = 0.5;
    int empty_scans = 1;
    double jitter_deg = -1.0;  ///< >= 0: rotation only, instead of the table's 5 deg / 10 cm
    double noise_m = 0.0;      ///< > 0: instead of the seed's sensor noise
};

/// One case of FamilyTable in detail: the set-up, the alignment at the true pose and at the
/// found one, and the error of every cell's empty and soil heights against the truth. Returns
/// a process exit code.
int FamilyCase(const FamilyCaseOptions& options, std::ostream& out);

}  // namespace soilvol::bench
