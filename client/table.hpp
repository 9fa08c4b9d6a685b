#pragma once

#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace soilvol::client {

/// A text table with aligned columns: numeric columns right-aligned, others left-aligned.
class Table {
  public:
    explicit Table(std::vector<std::string> headers) : headers_(std::move(headers)) {}

    /// Adds a row; missing cells print empty, extra cells are dropped.
    void AddRow(std::vector<std::string> cells);
    void Print(std::ostream& out) const;

  private:
    std::vector<std::string> headers_;
    std::vector<std::vector<std::string>> rows_;
};

/// Two aligned columns, label and value, for a single response.
using Fields = std::vector<std::pair<std::string, std::string>>;
void PrintFields(const Fields& fields, std::ostream& out);

/// `value` with `decimals` digits after the point ("-" for NaN).
std::string Fixed(double value, int decimals);

}  // namespace soilvol::client
