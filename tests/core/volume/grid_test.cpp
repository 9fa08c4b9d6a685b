#include "core/volume/grid.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace soilvol::volume {
namespace {

Polygon2d Rectangle(double x0, double y0, double width, double height) {
    return Polygon2d({{x0, y0}, {x0 + width, y0}, {x0 + width, y0 + height}, {x0, y0 + height}});
}

// The paper bucket's 0.54 m width over 3 cm cells is 18.000000000000004 cells in doubles: the
// count that limits the grid took a 19th row that MakeGrid never made.
TEST(GridTest, CellCountAndGridAgreeOnAnExactMultipleOfTheCell) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 2.05, 0.54);
    ASSERT_GT(0.54 / 0.03, 18.0);
    const Grid grid = MakeGrid(opening, 0.03);
    EXPECT_EQ(grid.cols, 69);
    EXPECT_EQ(grid.rows, 18);
    EXPECT_EQ(GridShape(opening, 0.03), Eigen::Vector2d(69.0, 18.0));
    EXPECT_EQ(GridCells(opening, 0.03), grid.NumCells());
}

TEST(GridTest, CellCountAndGridAgreeOverManySizes) {
    for (int i = 1; i <= 300; ++i) {
        const double side = 0.01 * i;
        const Polygon2d opening = Rectangle(0.0, 0.0, side, 0.5 * side + 0.01);
        for (const double cell : {0.02, 0.03, 0.07, 0.1}) {
            const Grid grid = MakeGrid(opening, cell);
            ASSERT_EQ(GridCells(opening, cell), grid.NumCells()) << side << " m, " << cell << " m";
            // Cells cover the opening, and no column or row lies wholly outside it.
            EXPECT_GE(grid.cols * cell, side - 1e-9 * cell);
            EXPECT_LT((grid.cols - 1) * cell, side);
        }
    }
}

TEST(GridTest, WeightsSumToTheOpeningArea) {
    const Polygon2d opening({{0.0, 0.0}, {2.05, 0.0}, {2.05, 0.54}, {0.3, 0.8}});
    const Grid grid = MakeGrid(opening, 0.07);
    double area = 0.0;
    for (const double w : grid.weight) area += w;
    EXPECT_NEAR(area, opening.Area(), 1e-9);
}

}  // namespace
}  // namespace soilvol::volume
