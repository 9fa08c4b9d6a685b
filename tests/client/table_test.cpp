#include "client/table.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

namespace soilvol::client {
namespace {

TEST(Table, AlignsNumbersRightAndTextLeft) {
    Table table({"id", "volume [L]"});
    table.AddRow({"bucket", "12.5"});
    table.AddRow({"b", "-3.0"});
    std::ostringstream out;
    table.Print(out);
    EXPECT_EQ(out.str(),
              "id      volume [L]\n"
              "bucket        12.5\n"
              "b             -3.0\n");
}

TEST(Table, MissingCellsPrintEmptyAndExtraCellsAreDropped) {
    Table table({"a", "b"});
    table.AddRow({"x"});
    table.AddRow({"y", "z", "dropped"});
    std::ostringstream out;
    table.Print(out);
    EXPECT_EQ(out.str(), "a  b\nx\ny  z\n");
}

TEST(PrintFields, AlignsValues) {
    std::ostringstream out;
    PrintFields({{"id", "a"}, {"depth [m]", "0.6"}}, out);
    EXPECT_EQ(out.str(), "id         a\ndepth [m]  0.6\n");
}

TEST(Fixed, RoundsAndShowsNanAsDash) {
    EXPECT_EQ(Fixed(1.26, 1), "1.3");
    EXPECT_EQ(Fixed(664.24, 0), "664");
    EXPECT_EQ(Fixed(std::nan(""), 2), "-");
}

}  // namespace
}  // namespace soilvol::client
