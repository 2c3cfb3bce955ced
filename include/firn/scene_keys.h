// The scene keys as the manual documents them (docs/reference/scene.md), kept beside the parser
// so that the reference cannot drift: `firn keys --markdown` prints the page's tables from here,
// and the tests compare them with the page and with the keys the parser reads.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

namespace firn {

/// One row of a scene-reference table. Every field is Markdown as the table shows it.
struct SceneKeyDoc {
    const char* section;      ///< the scene table: "simulation", "grid", "material", ...
    const char* keys;         ///< one key in backticks, or several that go together
    const char* defaultValue; ///< "`0.05`", "required", "none", ...
    const char* models;       ///< [[material]] only: the models the key applies to
    const char* meaning;      ///< what the key means, its unit and range
};

/// Every documented key, table by table in the manual's order.
const std::vector<SceneKeyDoc>& sceneKeyDocs();

/// The scene tables in the manual's order: simulation, grid, material, terrain, body, cut, ...
std::vector<std::string> sceneKeySections();

/// The key names of one row: "`min`, `max`" gives {"min", "max"}.
std::vector<std::string> keyNames(const SceneKeyDoc& doc);

/// The Markdown table of one scene table's keys, as the manual shows it (no trailing newline).
std::string sceneKeyTable(const std::string& section);

/// The line before a generated table in the manual: "<!-- firn keys --markdown: [grid] -->"
/// for a scene table, "[metrics.csv]" and "[summary.json]" for the outputs' tables.
std::string keyTableBegin(const std::string& table);
/// The line after each generated table.
extern const char* const kKeyTableEnd;

/// The keys the parser reads (asks for, or rejects as belonging to another model or shape) in
/// each table of the scene at `path`, with `overrides` applied: "grid" -> {"dx", "cfl", ...}.
/// Throws SceneError as loadScene does.
std::map<std::string, std::set<std::string>>
sceneKeysRead(const std::string& path, const std::vector<std::string>& overrides = {});

} // namespace firn
