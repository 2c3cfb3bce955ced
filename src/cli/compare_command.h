// `firn compare RUN_A RUN_B [options]`: argument parsing and the command, apart from main.cc
// like `firn render`.
#pragma once

#include <firn/compare.h>

#include <string>
#include <vector>

namespace firn::cli {

extern const char* const kCompareHelp;

struct CompareCommand {
    CompareOptions options;
    bool help = false;
};

/// Parses the arguments after `firn compare`; throws std::invalid_argument with a message.
CompareCommand parseCompareCommand(const std::vector<std::string>& args);

/// Compares, prints the verdict, what moved and the page's path. Returns the exit code: 0 when
/// every figure is within tolerance, 5 when one moved.
int runCompareCommand(const CompareCommand& command);

} // namespace firn::cli
