// The columns of metrics.csv and the keys of summary.json as the manual documents them
// (docs/reference/outputs.md), kept beside the writers so that the reference cannot drift:
// metrics.csv takes its header from here, `firn keys --markdown` prints the page's tables, and
// the tests compare them with the page and with the keys the summary writer sets.
#pragma once

#include <string>
#include <vector>

namespace firn {

/// One row of an output table; `unit` and `meaning` are Markdown.
struct OutputKeyDoc {
    const char* name;
    const char* unit; ///< "m", "kg (2D: kg/m)", "" for counts and words
    const char* meaning;
};

/// The columns of metrics.csv, in the file's order (the contract's core columns first).
const std::vector<OutputKeyDoc>& metricColumnDocs();

/// The top-level keys of summary.json, in the order the writer sets them.
const std::vector<OutputKeyDoc>& summaryKeyDocs();

/// The names of metricColumnDocs(): metrics.csv's header.
std::vector<std::string> metricColumns();

/// The Markdown table of "metrics.csv" or "summary.json", as the manual shows it.
std::string outputKeyTable(const std::string& file);

} // namespace firn
