// --set overrides: "key.path=value" edits of the parsed document, made before validation so
// that overridden values are checked exactly like those in the file.
#pragma once

#include <toml++/toml.h>

#include <string>
#include <vector>

namespace firn::scene {

/// The file that messages name for a value set with --set; also the source path toml++ records
/// for the keys of an inline table given there, the only override nodes that keep a position.
inline const std::string kOverrideFile = "--set";

/// Applies each override in order. "table.key=value" sets a key of a plain table (created if
/// the file has none); "material.<name>.key=value" (or body) sets a key of the [[material]]
/// entry whose `name` matches. The value is read as a TOML value, or as a string when it is not
/// one (so `grid.transfer=flip` works unquoted). Keys are not checked here: validation reports
/// an unknown one at location "--set", as the nodes made here carry no source position.
/// Throws SceneError (file "--set") for a malformed override or an entry name that matches none.
void applyOverrides(toml::table& root, const std::vector<std::string>& overrides);

} // namespace firn::scene
