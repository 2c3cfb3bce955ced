// TOML syntax errors as a compiler reports them: file, line and column, the key or table being
// parsed, and the offending line with a caret under the column.
#pragma once

#include <firn/errors.h>

#include <string>

namespace firn::scene {

/// The key whose value, or the table whose header, holds `line` of `text` (1-based), spelled
/// as validation messages spell it: "grid.dx", "body 2: thickness", "material \"slab\": density";
/// a table name for an error in its header; "" when the line is in neither.
std::string keyAtLine(const std::string& text, int line);

/// Two lines: `line` of `text` with its number, and a caret under `column` (1-based).
std::string sourceExcerpt(const std::string& text, int line, int column);

/// A SceneError for a parse error at (line, column) of `text`, read from `path`.
SceneError syntaxError(const std::string& text, const std::string& path, int line, int column,
                       const std::string& description);

} // namespace firn::scene
