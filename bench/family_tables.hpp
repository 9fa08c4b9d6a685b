#pragma once

#include <ostream>
#include <string>

namespace soilvol::bench {

/// Every container family (core/sim) with random dimensions, sensors (1-4 cm noise, 0.2-0.5 deg,
/// 0-2% outliers) and moves up to 5 deg / 10 cm, from empty to heaped; errors in % of struck
/// capacity and the share of estimates within 2 reported sigmas.
std::string FamilyTable(int seeds, std::ostream& kv);

/// One case of FamilyTable in detail: the set-up, the figures, and the error of every cell's
/// soil height against the truth. Returns a process exit code.
int FamilyCase(int family_index, int seed, double fill_share, std::ostream& out);

}  // namespace soilvol::bench
