#include "report/metrics_table.h"

#include <firn/errors.h>

#include <fstream>
#include <limits>
#include <sstream>

namespace firn::report {
namespace {

std::vector<std::string> splitCommas(const std::string& line) {
    std::vector<std::string> cells;
    std::stringstream in(line);
    std::string cell;
    while (std::getline(in, cell, ',')) cells.push_back(cell);
    if (!line.empty() && line.back() == ',') cells.emplace_back(); // a trailing empty cell
    return cells;
}

double parseCell(const std::string& cell, const std::string& where) {
    if (cell.empty()) return std::numeric_limits<double>::quiet_NaN();
    try {
        std::size_t used = 0;
        const double value = std::stod(cell, &used);
        if (used == cell.size()) return value;
    } catch (const std::exception&) {
    }
    throw IoError(where + ": not a number: '" + cell + "'");
}

} // namespace

const std::vector<double>& MetricsTable::column(const std::string& name) const {
    const auto it = columns.find(name);
    if (it == columns.end()) throw IoError(path + ": no column '" + name + "'");
    return it->second;
}

MetricsTable readMetrics(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw IoError("cannot read " + path + ": no such file (is this a firn run folder?)");
    MetricsTable table;
    table.path = path;
    std::string line;
    if (!std::getline(in, line)) throw IoError(path + ": empty file, expected a header row");
    const std::vector<std::string> header = splitCommas(line);
    for (const auto& name : header) table.columns[name];
    for (int lineNo = 2; std::getline(in, line); ++lineNo) {
        if (line.empty()) continue;
        const std::string where = path + ":" + std::to_string(lineNo);
        const std::vector<std::string> cells = splitCommas(line);
        if (cells.size() != header.size()) {
            throw IoError(where + ": " + std::to_string(cells.size()) + " cells, the header has " +
                          std::to_string(header.size()));
        }
        for (std::size_t c = 0; c < cells.size(); ++c) {
            table.columns[header[c]].push_back(parseCell(cells[c], where));
        }
        ++table.rows;
    }
    return table;
}

} // namespace firn::report
