// The scene.toml files of two runs, key path by key path: what makes them different scenes,
// and which parameters changed within one scene.
#include <firn/compare.h>

#include <firn/errors.h>
#include <firn/io.h>

#include <toml++/toml.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace firn {
namespace {

const char* const kAbsent = "(absent)";

/// Keys of an entity in an array of tables that say what kind of thing it is: another value
/// makes another scene, not another parameter of the same one.
bool isKindKey(const std::string& leaf) {
    static const std::set<std::string> kinds = {"model", "shape",     "material",
                                                "file",  "on_top_of", "layer"};
    return kinds.count(leaf) > 0;
}

/// Values as short TOML-like text: numbers in their shortest round-trip form (toml++ would
/// write 0.1 as 0.10000000000000001).
std::string valueText(const toml::node& node) {
    if (const auto* f = node.as_floating_point()) return formatNumber(f->get());
    if (const auto* i = node.as_integer()) return std::to_string(i->get());
    if (const auto* s = node.as_string()) return "\"" + s->get() + "\"";
    if (const auto* b = node.as_boolean()) return b->get() ? "true" : "false";
    if (const auto* a = node.as_array()) {
        std::string text = "[";
        for (std::size_t i = 0; i < a->size(); ++i) text += (i ? ", " : "") + valueText(*a->get(i));
        return text + "]";
    }
    std::ostringstream other; // dates and times
    node.visit([&](const auto& value) { other << value; });
    return other.str();
}

bool isArrayOfTables(const toml::node& node) {
    const auto* a = node.as_array();
    return a && !a->empty() && a->is_homogeneous(toml::node_type::table);
}

/// key path -> value text; arrays of tables also record their length under the bare key path
/// (with "#" appended), which is structural.
using FlatScene = std::map<std::string, std::string>;

void flatten(const toml::table& table, const std::string& prefix, FlatScene& out);

void flattenEntries(const toml::array& entries, const std::string& key, FlatScene& out) {
    out[key + "#"] = std::to_string(entries.size()) + " entries";
    for (std::size_t i = 0; i < entries.size(); ++i) {
        const toml::table& entry = *entries.get(i)->as_table();
        const auto name = entry["name"].value<std::string>();
        flatten(entry, name ? key + "." + *name : key + "[" + std::to_string(i) + "]", out);
    }
}

void flatten(const toml::table& table, const std::string& prefix, FlatScene& out) {
    for (const auto& [k, node] : table) {
        const std::string key =
            prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
        if (key == "output.directory") continue; // where it was written, not what ran
        if (const auto* sub = node.as_table())
            flatten(*sub, key, out);
        else if (isArrayOfTables(node))
            flattenEntries(*node.as_array(), key, out);
        else
            out[key] = valueText(node);
    }
}

FlatScene readScene(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw IoError("cannot read " + path + " (is its folder written by `firn run`?)");
    std::ostringstream text;
    text << in.rdbuf();
    try {
        FlatScene flat;
        flatten(toml::parse(text.str(), std::string_view(path)), "", flat);
        return flat;
    } catch (const toml::parse_error& e) {
        const auto& at = e.source().begin;
        throw SceneError(SourceLoc{path, int(at.line), int(at.column)}, "syntax",
                         std::string(e.description()));
    }
}

bool isStructural(const std::string& key, bool presentInBoth) {
    if (key == "simulation.dimension") return true;
    if (!key.empty() && key.back() == '#') return true; // a different number of entities
    const std::size_t dot = key.rfind('.');
    const std::string leaf = dot == std::string::npos ? key : key.substr(dot + 1);
    // An entity whose kind changed, or one that only one scene has (a named material, say).
    const bool inEntity =
        key.find('[') != std::string::npos || std::count(key.begin(), key.end(), '.') >= 2;
    return inEntity && (isKindKey(leaf) || (!presentInBoth && leaf == "name"));
}

} // namespace

std::vector<SceneDifference> diffScenes(const std::string& sceneA, const std::string& sceneB) {
    const FlatScene a = readScene(sceneA), b = readScene(sceneB);
    std::set<std::string> keys;
    for (const auto& [k, v] : a) keys.insert(k);
    for (const auto& [k, v] : b) keys.insert(k);
    std::vector<SceneDifference> differences;
    for (const std::string& key : keys) {
        const auto ia = a.find(key), ib = b.find(key);
        const bool inA = ia != a.end(), inB = ib != b.end();
        if (inA && inB && ia->second == ib->second) continue;
        SceneDifference d;
        d.key = key.back() == '#' ? key.substr(0, key.size() - 1) : key;
        d.a = inA ? ia->second : kAbsent;
        d.b = inB ? ib->second : kAbsent;
        d.structural = isStructural(key, inA && inB);
        differences.push_back(d);
    }
    return differences;
}

} // namespace firn
