#include "overrides.h"

#include <firn/errors.h>

#include <algorithm>
#include <string_view>

namespace firn::scene {
namespace {

const SourceLoc kSetLoc{kOverrideFile, 0, 0};
const char* const kUsage =
    "expected <table>.<key>=<value>, <material|body>.<name>.<key>=<value> or "
    "cut.<layer>.<key>=<value>";

std::string trim(std::string_view text) {
    const auto first = text.find_first_not_of(" \t");
    if (first == std::string_view::npos) return {};
    const auto last = text.find_last_not_of(" \t");
    return std::string(text.substr(first, last - first + 1));
}

std::vector<std::string> splitPath(const std::string& path) {
    std::vector<std::string> parts;
    std::size_t start = 0;
    for (std::size_t dot = path.find('.'); dot != std::string::npos; dot = path.find('.', start)) {
        parts.push_back(path.substr(start, dot - start));
        start = dot + 1;
    }
    parts.push_back(path.substr(start));
    return parts;
}

// The entry of an [[array]] whose `name` is `name` (a [[cut]] is named by its `layer`).
toml::table& namedEntry(toml::array& array, const std::string& arrayKey, const std::string& name,
                        const std::string& path) {
    const char* idKey = arrayKey == "cut" ? "layer" : "name";
    std::string names;
    for (toml::node& item : array) {
        toml::table* entry = item.as_table();
        const auto* entryName = entry ? entry->get_as<std::string>(idKey) : nullptr;
        if (!entryName) continue;
        if (entryName->get() == name) return *entry;
        names += (names.empty() ? "" : ", ") + entryName->get();
    }
    throw SceneError(kSetLoc, path,
                     "no [[" + arrayKey + "]] named \"" + name +
                         "\" (named: " + (names.empty() ? "none" : names) + ")");
}

// The table that holds the last part of `parts`; plain tables missing from the file are made.
toml::table& targetTable(toml::table& root, const std::vector<std::string>& parts,
                         const std::string& path) {
    toml::table* table = &root;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
        const bool selectsEntry = i + 2 < parts.size(); // material.<name>.key
        toml::node* node = table->get(parts[i]);
        if (!node && selectsEntry) {
            toml::array none;
            namedEntry(none, parts[i], parts[i + 1], path); // throws: no entry of that name
        }
        if (!node) node = table->insert_or_assign(parts[i], toml::table{}).first->second.as_table();
        if (node->is_table()) {
            table = node->as_table();
        } else if (node->is_array_of_tables() && selectsEntry) {
            table = &namedEntry(*node->as_array(), parts[i], parts[i + 1], path);
            ++i;
        } else {
            throw SceneError(kSetLoc, path, kUsage);
        }
    }
    return *table;
}

/// Well-formed UTF-8 (RFC 3629: no overlong forms, surrogates or code points past U+10FFFF).
/// TOML text is UTF-8; a bare-word value of other bytes would be written altered into the
/// as-run scene.toml and read back as something else.
bool validUtf8(std::string_view text) {
    for (std::size_t i = 0; i < text.size();) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        int length = 0;
        unsigned lo = 0x80, hi = 0xBF; // the second byte's range
        if (c < 0x80) {
            ++i;
            continue;
        } else if (c >= 0xC2 && c <= 0xDF) {
            length = 2;
        } else if (c >= 0xE0 && c <= 0xEF) {
            length = 3;
            if (c == 0xE0) lo = 0xA0;
            if (c == 0xED) hi = 0x9F;
        } else if (c >= 0xF0 && c <= 0xF4) {
            length = 4;
            if (c == 0xF0) lo = 0x90;
            if (c == 0xF4) hi = 0x8F;
        } else {
            return false;
        }
        if (i + length > text.size()) return false;
        for (int k = 1; k < length; ++k) {
            const unsigned char next = static_cast<unsigned char>(text[i + k]);
            if (next < (k == 1 ? lo : 0x80) || next > (k == 1 ? hi : 0xBF)) return false;
        }
        i += length;
    }
    return true;
}

void applyOverride(toml::table& root, const std::string& text) {
    if (!validUtf8(text)) throw SceneError(kSetLoc, "", "not valid UTF-8 text");
    const auto eq = text.find('=');
    const std::string path = trim(std::string_view(text).substr(0, eq));
    if (eq == std::string::npos) throw SceneError(kSetLoc, path, kUsage);
    const std::vector<std::string> parts = splitPath(path);
    const auto isEmpty = [](const std::string& part) { return part.empty(); };
    if (parts.size() < 2 || std::any_of(parts.begin(), parts.end(), isEmpty)) {
        throw SceneError(kSetLoc, path, kUsage);
    }
    toml::table& table = targetTable(root, parts, path);
    const std::string value = trim(std::string_view(text).substr(eq + 1));
    try {
        const toml::table parsed = toml::parse("v = " + value, std::string_view(kOverrideFile));
        // Copying a node drops its source position, which is how validation tells "--set".
        if (const toml::node* node = parsed.get("v")) {
            node->visit([&](const auto& v) { table.insert_or_assign(parts.back(), v); });
            return;
        }
    } catch (const toml::parse_error&) {
        // Not a TOML value: a bare word, taken as a string below.
    }
    table.insert_or_assign(parts.back(), value);
}

} // namespace

void applyOverrides(toml::table& root, const std::vector<std::string>& overrides) {
    for (const auto& text : overrides) applyOverride(root, text);
}

} // namespace firn::scene
