#pragma once

#include <ostream>
#include <string>

namespace soilvol::bench {

/// Each table runs its trials, prints `key=value` lines to `kv` and returns a markdown section.

/// Paper Table 1: the paper bucket filled 0-60 cm, 10 cm grid, both methods.
std::string FillTable(int seeds, std::ostream& kv);
/// Paper Table 2: the full paper bucket on grids of 3-15 cm, both methods.
std::string GridTable(int seeds, std::ostream& kv);
/// The other containers at several fills and a heap, automatic cell size.
std::string ContainerTable(int seeds, std::ostream& kv);
/// Sensor and set-up variations on the paper bucket half full.
std::string RobustnessTable(int seeds, std::ostream& kv);
/// Time per stage on a dense ~100k-point scan.
std::string SpeedTable(int repetitions, std::ostream& kv);
/// The filled paper bucket scanned at 20k to 1M points (the speed table's scenes), several
/// seeds: accuracy against scan density, automatic and fixed cells.
std::string DensityTable(int seeds, std::ostream& kv);

}  // namespace soilvol::bench
