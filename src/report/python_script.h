// The chart scripts under render/ (report.py, compare.py), found and run without a shell.
#pragma once

#include <string>
#include <vector>

namespace firn::report {

/// render/<name> of this checkout, or of $FIRN_RENDER_SCRIPTS when set. Throws IoError when
/// the file is not there.
std::string renderScriptPath(const std::string& name);

/// Runs /usr/bin/python3 `script` `args...` and waits for it. No shell is involved, so no folder
/// name is ever parsed as shell syntax. Throws IoError when python cannot start or the script
/// fails (its own messages go to stderr).
void runPythonScript(const std::string& script, const std::vector<std::string>& args);

} // namespace firn::report
