#include "client/table.hpp"

#include <algorithm>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_format.h"

namespace soilvol::client {
namespace {

bool IsNumeric(const std::string& cell) {
    double value = 0.0;
    return cell.empty() || cell == "-" || absl::SimpleAtod(cell, &value);
}

}  // namespace

void Table::AddRow(std::vector<std::string> cells) {
    cells.resize(headers_.size());
    rows_.push_back(std::move(cells));
}

void Table::Print(std::ostream& out) const {
    const size_t columns = headers_.size();
    std::vector<size_t> width(columns);
    std::vector<bool> right(columns, !rows_.empty());
    for (size_t c = 0; c < columns; ++c) {
        width[c] = headers_[c].size();
        for (const auto& row : rows_) {
            width[c] = std::max(width[c], row[c].size());
            right[c] = right[c] && IsNumeric(row[c]);
        }
    }
    const auto print_row = [&](const std::vector<std::string>& cells) {
        std::string line;
        for (size_t c = 0; c < columns; ++c) {
            const std::string pad(width[c] - cells[c].size(), ' ');
            line += (c == 0 ? "" : "  ") + (right[c] ? pad + cells[c] : cells[c] + pad);
        }
        line.erase(line.find_last_not_of(' ') + 1);
        out << line << "\n";
    };
    print_row(headers_);
    for (const auto& row : rows_) print_row(row);
}

void PrintFields(const Fields& fields, std::ostream& out) {
    size_t width = 0;
    for (const auto& [label, value] : fields) width = std::max(width, label.size());
    for (const auto& [label, value] : fields) {
        out << label << std::string(width + 2 - label.size(), ' ') << value << "\n";
    }
}

std::string Fixed(double value, int decimals) {
    if (std::isnan(value)) return "-";
    return absl::StrFormat("%.*f", decimals, value);
}

}  // namespace soilvol::client
