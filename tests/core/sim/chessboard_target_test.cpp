#include "core/sim/chessboard_target.hpp"

#include <gtest/gtest.h>

namespace soilvol::sim {
namespace {

constexpr double kSquareM = 0.05;

std::vector<Eigen::Vector2d> Square(const Eigen::Vector2d& centre, double half) {
    return {centre + Eigen::Vector2d(-half, -half), centre + Eigen::Vector2d(half, -half),
            centre + Eigen::Vector2d(half, half), centre + Eigen::Vector2d(-half, half)};
}

TEST(ChessboardTargetTest, CornersRunAlongColsThenRows) {
    const ChessboardTarget board(9, 6, kSquareM);
    EXPECT_TRUE(board.Corner(0, 0).isZero());
    EXPECT_TRUE(board.Corner(8, 5).isApprox(Eigen::Vector3d(0.4, 0.25, 0.0), 1e-15));
    EXPECT_TRUE(board.Centre().isApprox(Eigen::Vector3d(0.2, 0.125, 0.0), 1e-15));
    // The outline runs around the ring: x from -2 to 10 squares, y from -2 to 7.
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
    for (const Eigen::Vector3d& p : board.Outline(4)) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    EXPECT_TRUE(lo.isApprox(Eigen::Vector3d(-0.1, -0.1, 0.0), 1e-12));
    EXPECT_TRUE(hi.isApprox(Eigen::Vector3d(0.5, 0.35, 0.0), 1e-12));
}

TEST(ChessboardTargetTest, CoverageSplitsPolygonsExactly) {
    const ChessboardTarget board(9, 6, kSquareM);
    // Inside the top-left (black) square and its white neighbour.
    EXPECT_EQ(board.Cover(Square({-0.025, -0.025}, 0.01)).black, 1.0);
    EXPECT_EQ(board.Cover(Square({0.025, -0.025}, 0.01)).white, 1.0);
    // Centred on inner corner (1, 1): two black and two white quarters.
    const BoardCoverage corner = board.Cover(Square({0.05, 0.05}, 0.01));
    EXPECT_NEAR(corner.black, 0.5, 1e-12);
    EXPECT_NEAR(corner.white, 0.5, 1e-12);
    // A quarter across the edge x = 0 between black (0, 0) and white (1, 0).
    const BoardCoverage edge = board.Cover(Square({-0.005, -0.025}, 0.02));
    EXPECT_NEAR(edge.black, 0.625, 1e-12);
    EXPECT_NEAR(edge.white, 0.375, 1e-12);
    // Across the outer edge of the ring at x = -0.1, and far off the board.
    const BoardCoverage outer = board.Cover(Square({-0.1, 0.1}, 0.01));
    EXPECT_NEAR(outer.white, 0.5, 1e-12);
    EXPECT_NEAR(outer.off_board, 0.5, 1e-12);
    EXPECT_EQ(board.Cover(Square({-3.0, 5.0}, 0.5)).off_board, 1.0);
    // A rotated triangle over the board corner: shares still add up to one.
    const BoardCoverage triangle = board.Cover({{-0.13, -0.12}, {-0.05, -0.11}, {-0.09, -0.04}});
    EXPECT_NEAR(triangle.black + triangle.white + triangle.off_board, 1.0, 1e-12);
    EXPECT_GT(triangle.white, 0.0);
    EXPECT_GT(triangle.off_board, 0.0);
}

TEST(ChessboardTargetTest, DegeneratePolygonCountsAtItsFirstVertex) {
    const ChessboardTarget board(9, 6, kSquareM);
    const Eigen::Vector2d p(0.0001, 0.0);  // on the edge between squares (1, 0) and (1, 1)
    const BoardCoverage point = board.Cover({p, p, p});
    EXPECT_EQ(point.black + point.white + point.off_board, 1.0);
}

}  // namespace
}  // namespace soilvol::sim
