#pragma once

#include <Eigen/Core>
#include <vector>

namespace soilvol::sim {

/// Share of a board-plane region on black squares, white squares and ring, and off the board.
struct BoardCoverage {
    double black = 0.0;
    double white = 0.0;
    double off_board = 0.0;
};

/// A printed calibration chessboard in its own frame (x along cols, y along rows, z normal):
/// inner corner (i, j) at (i, j) * square_m; (cols + 1) x (rows + 1) squares, the top-left one
/// black, inside a white ring one square wide.
class ChessboardTarget {
  public:
    static constexpr double kBlackAlbedo = 0.08;
    static constexpr double kWhiteAlbedo = 0.85;

    ChessboardTarget(int cols, int rows, double square_m);

    /// Inner corner (i, j) [m], board frame.
    Eigen::Vector3d Corner(int i, int j) const;
    /// Centre of the inner corners [m], board frame.
    Eigen::Vector3d Centre() const;
    /// `per_side` points along each side of the outer edge of the ring [m], board frame.
    std::vector<Eigen::Vector3d> Outline(int per_side) const;
    /// Exact area shares of the convex board-plane polygon `polygon` [m] (>= 3 vertices in
    /// order); a degenerate polygon counts where its first vertex lies.
    BoardCoverage Cover(const std::vector<Eigen::Vector2d>& polygon) const;

  private:
    Eigen::Vector2i Cell(const Eigen::Vector2d& xy) const;
    double CellEdge(int index, int last) const;
    void AddCell(const Eigen::Vector2i& cell, double area, BoardCoverage* coverage) const;

    int cols_;
    int rows_;
    double square_m_;
};

}  // namespace soilvol::sim
