#include "core/sim/chessboard_target.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::sim {

namespace {

constexpr double kUnbounded = 1e9;

// Sutherland-Hodgman: the part of convex `polygon` with coordinate `axis` on the `keep_below`
// side of `bound`.
std::vector<Eigen::Vector2d> ClipPolygon(const std::vector<Eigen::Vector2d>& polygon, int axis,
                                         double bound, bool keep_below) {
    std::vector<Eigen::Vector2d> clipped;
    const auto inside = [&](const Eigen::Vector2d& p) {
        return keep_below ? p[axis] <= bound : p[axis] >= bound;
    };
    for (size_t i = 0; i < polygon.size(); ++i) {
        const Eigen::Vector2d& a = polygon[i];
        const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
        if (inside(a)) clipped.push_back(a);
        if (inside(a) != inside(b)) {
            clipped.push_back(a + (bound - a[axis]) / (b[axis] - a[axis]) * (b - a));
        }
    }
    return clipped;
}

double PolygonArea(const std::vector<Eigen::Vector2d>& polygon) {
    double twice = 0.0;
    for (size_t i = 0; i < polygon.size(); ++i) {
        const Eigen::Vector2d& a = polygon[i];
        const Eigen::Vector2d& b = polygon[(i + 1) % polygon.size()];
        twice += a.x() * b.y() - a.y() * b.x();
    }
    return 0.5 * std::abs(twice);
}

}  // namespace

ChessboardTarget::ChessboardTarget(int cols, int rows, double square_m)
    : cols_(cols), rows_(rows), square_m_(square_m) {}

Eigen::Vector3d ChessboardTarget::Corner(int i, int j) const {
    return {i * square_m_, j * square_m_, 0.0};
}

Eigen::Vector3d ChessboardTarget::Centre() const {
    return {0.5 * (cols_ - 1) * square_m_, 0.5 * (rows_ - 1) * square_m_, 0.0};
}

std::vector<Eigen::Vector3d> ChessboardTarget::Outline(int per_side) const {
    const double x0 = -2.0 * square_m_;
    const double y0 = -2.0 * square_m_;
    const double x1 = (cols_ + 1) * square_m_;
    const double y1 = (rows_ + 1) * square_m_;
    const Eigen::Vector3d corners[4] = {{x0, y0, 0.0}, {x1, y0, 0.0}, {x1, y1, 0.0}, {x0, y1, 0.0}};
    std::vector<Eigen::Vector3d> outline;
    for (int s = 0; s < 4; ++s) {
        for (int k = 0; k < per_side; ++k) {
            const double f = static_cast<double>(k) / per_side;
            outline.push_back((1.0 - f) * corners[s] + f * corners[(s + 1) % 4]);
        }
    }
    return outline;
}

// Cell (a, b): squares 0..cols / 0..rows, the ring at -1 and cols / rows + 1, and everything
// beyond merged into the convex off-board strips and quadrants -2 and cols / rows + 2.
Eigen::Vector2i ChessboardTarget::Cell(const Eigen::Vector2d& xy) const {
    const double a = std::clamp(std::floor(xy.x() / square_m_) + 1.0, -2.0, cols_ + 2.0);
    const double b = std::clamp(std::floor(xy.y() / square_m_) + 1.0, -2.0, rows_ + 2.0);
    return {static_cast<int>(a), static_cast<int>(b)};
}

// Lower edge [m] of cell `index` along an axis with `last` the last square.
double ChessboardTarget::CellEdge(int index, int last) const {
    if (index <= -2) return -kUnbounded;
    if (index > last + 2) return kUnbounded;
    return (index - 1) * square_m_;
}

void ChessboardTarget::AddCell(const Eigen::Vector2i& cell, double area,
                               BoardCoverage* coverage) const {
    const int a = cell.x();
    const int b = cell.y();
    if (a < -1 || a > cols_ + 1 || b < -1 || b > rows_ + 1) {
        coverage->off_board += area;
    } else if (a >= 0 && a <= cols_ && b >= 0 && b <= rows_ && (a + b) % 2 == 0) {
        coverage->black += area;
    } else {
        coverage->white += area;
    }
}

BoardCoverage ChessboardTarget::Cover(const std::vector<Eigen::Vector2d>& polygon) const {
    BoardCoverage coverage;
    Eigen::Vector2i lo = Cell(polygon.front());
    Eigen::Vector2i hi = lo;
    for (const Eigen::Vector2d& p : polygon) {
        lo = lo.cwiseMin(Cell(p));
        hi = hi.cwiseMax(Cell(p));
    }
    if (lo == hi) {
        AddCell(lo, 1.0, &coverage);
        return coverage;
    }
    // Clip the polygon to every cell of its bounding range (cells are convex).
    double total = 0.0;
    for (int a = lo.x(); a <= hi.x(); ++a) {
        for (int b = lo.y(); b <= hi.y(); ++b) {
            std::vector<Eigen::Vector2d> part = ClipPolygon(polygon, 0, CellEdge(a, cols_), false);
            part = ClipPolygon(part, 0, CellEdge(a + 1, cols_), true);
            part = ClipPolygon(part, 1, CellEdge(b, rows_), false);
            part = ClipPolygon(part, 1, CellEdge(b + 1, rows_), true);
            const double area = part.size() >= 3 ? PolygonArea(part) : 0.0;
            AddCell(Eigen::Vector2i(a, b), area, &coverage);
            total += area;
        }
    }
    if (!(total > 0.0)) {
        coverage = BoardCoverage();
        AddCell(Cell(polygon.front()), 1.0, &coverage);
        return coverage;
    }
    coverage.black /= total;
    coverage.white /= total;
    coverage.off_board /= total;
    return coverage;
}

}  // namespace soilvol::sim
