#include "syntax_error.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <sstream>
#include <vector>

namespace firn::scene {
namespace {

std::vector<std::string> splitLines(const std::string& text) {
    std::vector<std::string> lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);) {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        lines.push_back(line);
    }
    return lines;
}

std::string trim(const std::string& s) {
    std::size_t b = 0, e = s.size();
    while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
    while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
    return s.substr(b, e - b);
}

/// "[name]" or "[[name]]" at the start of a line: the name, and whether it is an array entry.
bool tableHeader(const std::string& line, std::string& name, bool& array) {
    const std::string t = trim(line);
    if (t.empty() || t[0] != '[') return false;
    array = t.size() > 1 && t[1] == '[';
    const std::size_t open = array ? 2 : 1;
    const std::size_t close = t.find(']', open);
    if (close == std::string::npos) {
        name = trim(t.substr(open));
        return true;
    }
    name = trim(t.substr(open, close - open));
    return true;
}

/// A bare or dotted key before '=' at the start of a line (not inside a string).
bool keyOfLine(const std::string& line, std::string& key) {
    const std::string t = trim(line);
    const std::size_t eq = t.find('=');
    if (eq == std::string::npos || eq == 0) return false;
    const std::string k = trim(t.substr(0, eq));
    for (char c : k) {
        const bool ok = std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' ||
                        c == '.' || c == '"' || c == '\'' || c == ' ';
        if (!ok) return false;
    }
    key = k;
    return !k.empty();
}

/// `name = "..."` on a line: the quoted name.
bool nameOfLine(const std::string& line, std::string& name) {
    std::string key;
    if (!keyOfLine(line, key) || key != "name") return false;
    const std::string value = trim(line.substr(line.find('=') + 1));
    if (value.size() < 2 || (value[0] != '"' && value[0] != '\'')) return false;
    const std::size_t end = value.find(value[0], 1);
    if (end == std::string::npos) return false;
    name = value.substr(1, end - 1);
    return true;
}

} // namespace

std::string keyAtLine(const std::string& text, int line) {
    const std::vector<std::string> lines = splitLines(text);
    std::string table, key, entryName;
    bool array = false;
    std::map<std::string, int> entries; // [[name]] seen so far, for "body 3"
    const int last = std::min<int>(line, int(lines.size()));
    for (int i = 1; i <= last; ++i) {
        const std::string& l = lines[std::size_t(i - 1)];
        std::string header;
        bool isArray = false;
        if (tableHeader(l, header, isArray)) {
            table = header, array = isArray, key.clear(), entryName.clear();
            if (array) ++entries[table];
            if (i == line) return table;
            continue;
        }
        std::string k, n;
        if (keyOfLine(l, k)) key = k;
        if (array && nameOfLine(l, n)) entryName = n;
    }
    if (key.empty()) return table;
    if (table.empty()) return key;
    if (!array) return table + "." + key;
    // [[body]] entries are "body \"slab\": " or "body 3: " in validation messages; a name
    // given below the error line is not known here, so the number is used then.
    const std::string label =
        entryName.empty() ? std::to_string(entries[table]) : "\"" + entryName + "\"";
    return table + " " + label + ": " + key;
}

std::string sourceExcerpt(const std::string& text, int line, int column) {
    const std::vector<std::string> lines = splitLines(text);
    if (line < 1 || line > int(lines.size())) return "";
    const std::string& l = lines[std::size_t(line - 1)];
    const std::string number = std::to_string(line);
    std::string caret;
    // Tabs stay tabs so that the caret lines up however the terminal sets them.
    for (int c = 1; c < column && std::size_t(c - 1) < l.size(); ++c)
        caret += l[std::size_t(c - 1)] == '\t' ? '\t' : ' ';
    return " " + number + " | " + l + "\n " + std::string(number.size(), ' ') + " | " + caret + "^";
}

SceneError syntaxError(const std::string& text, const std::string& path, int line, int column,
                       const std::string& description) {
    const std::string key = keyAtLine(text, line);
    const std::string excerpt = sourceExcerpt(text, line, column);
    return SceneError(SourceLoc{path, line, column}, key.empty() ? "syntax" : key,
                      (key.empty() ? "" : "syntax error: ") + description +
                          (excerpt.empty() ? "" : "\n" + excerpt));
}

} // namespace firn::scene
