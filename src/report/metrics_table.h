// metrics.csv read back as numeric columns (outputs.md), for choosing the failure-map frames.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace firn::report {

/// Columns of metrics.csv by header name; empty cells read as NaN.
struct MetricsTable {
    std::string path;
    std::map<std::string, std::vector<double>> columns;
    std::size_t rows = 0;

    /// The column, or IoError naming `path` when metrics.csv has no such column.
    const std::vector<double>& column(const std::string& name) const;
};

/// Reads `path`; throws IoError naming the file and line on a malformed row.
MetricsTable readMetrics(const std::string& path);

} // namespace firn::report
