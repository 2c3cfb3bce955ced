#include "reader.h"

#include "overrides.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace firn::scene {
namespace {

const char* typeName(const toml::node& node) {
    switch (node.type()) {
    case toml::node_type::string:
        return "string";
    case toml::node_type::integer:
        return "integer";
    case toml::node_type::floating_point:
        return "float";
    case toml::node_type::boolean:
        return "boolean";
    case toml::node_type::date:
        return "date";
    case toml::node_type::time:
        return "time";
    case toml::node_type::date_time:
        return "date-time";
    case toml::node_type::array:
        return "array";
    case toml::node_type::table:
        return "table";
    default:
        return "nothing";
    }
}

// Edit distance, to suggest the key a typo probably meant.
std::size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
            diagonal = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitute});
        }
    }
    return row[b.size()];
}

std::string suggestion(std::string_view key, const std::set<std::string, std::less<>>& known) {
    std::string best;
    std::size_t bestDistance = 3; // more edits than this is a different word, not a typo
    for (const auto& candidate : known) {
        const std::size_t d = editDistance(key, candidate);
        if (d < bestDistance) {
            bestDistance = d;
            best = candidate;
        }
    }
    return best.empty() ? std::string() : "; did you mean '" + best + "'?";
}

std::string formatPoint(const std::array<double, 2>& p) {
    return "[" + formatNumber(p[0]) + ", " + formatNumber(p[1]) + "]";
}

// "a", "b", "c"
std::string quotedList(const std::vector<std::string>& words) {
    std::string list;
    for (const auto& w : words) list += (list.empty() ? "\"" : ", \"") + w + "\"";
    return list;
}

} // namespace

bool Range::contains(double v) const {
    const bool aboveLo = loOpen ? v > lo : v >= lo;
    const bool belowHi = hiOpen ? v < hi : v <= hi;
    return aboveLo && belowHi;
}

std::string Range::describe() const {
    if (std::isinf(hi)) return (loOpen ? "> " : ">= ") + formatNumber(lo);
    return std::string("in ") + (loOpen ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) +
           (hiOpen ? ")" : "]");
}

std::string formatNumber(double value) {
    std::ostringstream out;
    out.precision(15);
    out << value;
    return out.str();
}

TableReader::TableReader(const toml::table& table, const SceneContext& context, std::string prefix)
    : mTable(table)
    , mContext(context)
    , mPrefix(std::move(prefix)) {}

std::string TableReader::label() const {
    std::string out = mPrefix;
    while (!out.empty() && (out.back() == ' ' || out.back() == ':' || out.back() == '.')) {
        out.pop_back();
    }
    return out;
}

SourceLoc TableReader::locOf(const toml::source_region& region) const {
    // Nodes made by --set were not parsed from the file, so toml++ gives them no position
    // (values) or one in the override text (keys of an inline table).
    const auto& begin = region.begin;
    if (begin.line == 0 || (region.path && *region.path == kOverrideFile)) {
        return SourceLoc{kOverrideFile, 0, 0};
    }
    return SourceLoc{mContext.file, static_cast<int>(begin.line), static_cast<int>(begin.column)};
}

void TableReader::fail(const toml::node& node, std::string_view key,
                       const std::string& message) const {
    throw SceneError(locOf(node), keyName(key), message);
}

void TableReader::failAt(std::string_view key, const std::string& message) const {
    fail(*mTable.get(key), key, message);
}

void TableReader::failReference(std::string_view key, const std::string& message) const {
    throw SceneError(locOf(*mTable.get(key)), label(), message);
}

const toml::node* TableReader::find(std::string_view key) {
    mAsked.emplace(key);
    return mTable.get(key);
}

void TableReader::require(std::initializer_list<const char*> keys, const std::string& forWhat) {
    for (const char* key : keys) {
        if (has(key)) continue;
        const std::string why = forWhat.empty() ? "" : " for " + forWhat;
        throw SceneError(headerLoc(), keyName(key), "missing required key" + why);
    }
}

const toml::node* TableReader::typed(std::string_view key, TypeTest isType, const char* what) {
    const toml::node* node = find(key);
    if (node && !(node->*isType)()) {
        fail(*node, key, std::string("must be ") + what + ", got " + typeName(*node));
    }
    return node;
}

double TableReader::number(const toml::node& node, std::string_view key,
                           const std::string& what) const {
    const std::string subject = what.empty() ? "" : what + " ";
    if (!node.is_number()) fail(node, key, subject + "must be a number, got " + typeName(node));
    const double value =
        node.is_integer() ? static_cast<double>(**node.as_integer()) : **node.as_floating_point();
    // TOML allows inf and nan; neither is a meaningful length, time or modulus.
    if (!std::isfinite(value)) {
        fail(node, key, subject + "must be finite, got " + formatNumber(value));
    }
    return value;
}

bool TableReader::real(std::string_view key, double& out, const Range& range) {
    const toml::node* node = typed(key, &toml::node::is_number, "a number");
    if (!node) return false;
    const double value = number(*node, key, "");
    if (!range.contains(value)) {
        fail(*node, key, "must be " + range.describe() + ", got " + formatNumber(value));
    }
    out = value;
    return true;
}

bool TableReader::integer(std::string_view key, std::int64_t& out, const Range& range) {
    const toml::node* node = typed(key, &toml::node::is_integer, "an integer");
    if (!node) return false;
    const std::int64_t value = **node->as_integer();
    if (!range.contains(static_cast<double>(value))) {
        fail(*node, key, "must be " + range.describe() + ", got " + std::to_string(value));
    }
    out = value;
    return true;
}

bool TableReader::boolean(std::string_view key, bool& out) {
    const toml::node* node = typed(key, &toml::node::is_boolean, "a boolean");
    if (node) out = **node->as_boolean();
    return node != nullptr;
}

bool TableReader::string(std::string_view key, std::string& out) {
    const toml::node* node = typed(key, &toml::node::is_string, "a string");
    if (!node) return false;
    if (node->as_string()->get().empty()) fail(*node, key, "must not be empty");
    out = **node->as_string();
    return true;
}

bool TableReader::vector(std::string_view key, Vec3d& out) {
    const toml::node* node = typed(key, &toml::node::is_array, "an array of numbers");
    if (!node) return false;
    const toml::array& array = *node->as_array();
    const auto dim = static_cast<std::size_t>(mContext.dimension);
    if (array.size() != dim) {
        fail(*node, key,
             "must have " + std::to_string(dim) + " components in a " + std::to_string(dim) +
                 "D scene, got " + std::to_string(array.size()));
    }
    Vec3d value = {0.0, 0.0, 0.0};
    for (std::size_t i = 0; i < dim; ++i) {
        value[i] = number(array[i], key, "component " + std::to_string(i + 1));
    }
    out = value;
    return true;
}

bool TableReader::interval(std::string_view key, std::array<double, 2>& out) {
    const toml::node* node = typed(key, &toml::node::is_array, "an array [min, max]");
    if (!node) return false;
    const toml::array& array = *node->as_array();
    if (array.size() != 2) {
        fail(*node, key, "must have 2 components [min, max], got " + std::to_string(array.size()));
    }
    const std::array<double, 2> value = {number(array[0], key, "min"),
                                         number(array[1], key, "max")};
    if (!(value[0] < value[1])) fail(*node, key, "must have min < max, got " + formatPoint(value));
    out = value;
    return true;
}

bool TableReader::polyline(std::string_view key, std::vector<std::array<double, 2>>& out,
                           const std::string& yName) {
    const std::string pair = "[x, " + yName + "]";
    const toml::node* node =
        typed(key, &toml::node::is_array, ("an array of " + pair + " points").c_str());
    if (!node) return false;
    const toml::array& array = *node->as_array();
    if (array.size() < 2) {
        fail(*node, key, "must have at least 2 points, got " + std::to_string(array.size()));
    }
    std::vector<std::array<double, 2>> points;
    for (const toml::node& item : array) {
        const std::string what = "point " + std::to_string(points.size() + 1);
        const toml::array* xy = item.as_array();
        if (!xy || xy->size() != 2) fail(item, key, what + " must be an array " + pair);
        points.push_back(
            {number((*xy)[0], key, what + " x"), number((*xy)[1], key, what + " " + yName)});
        if (points.size() > 1 && !(points.back()[0] > points[points.size() - 2][0])) {
            fail(item, key,
                 "x must increase strictly, got " + formatPoint(points[points.size() - 2]) +
                     " then " + formatPoint(points.back()));
        }
    }
    out = std::move(points);
    return true;
}

bool TableReader::stringList(std::string_view key, std::vector<std::string>& out,
                             const std::vector<std::string>& allowed) {
    const toml::node* node = typed(key, &toml::node::is_array, "an array of strings");
    if (!node) return false;
    std::vector<std::string> words;
    for (const toml::node& item : *node->as_array()) {
        if (!item.is_string()) {
            fail(item, key, std::string("must hold strings, got ") + typeName(item));
        }
        const std::string& word = **item.as_string();
        if (std::find(allowed.begin(), allowed.end(), word) == allowed.end()) {
            fail(item, key,
                 "entries must be one of " + quotedList(allowed) + ", got \"" + word + "\"");
        }
        if (std::find(words.begin(), words.end(), word) != words.end()) {
            fail(item, key, "\"" + word + "\" is listed twice");
        }
        words.push_back(word);
    }
    out = std::move(words);
    return true;
}

int TableReader::pick(std::string_view key, const std::vector<std::string>& words) {
    std::string word;
    if (!string(key, word)) return -1;
    const auto it = std::find(words.begin(), words.end(), word);
    if (it != words.end()) return static_cast<int>(it - words.begin());
    failAt(key, "must be one of " + quotedList(words) + ", got \"" + word + "\"");
}

std::optional<TableReader> TableReader::subTable(std::string_view key, const std::string& prefix) {
    const toml::node* node = typed(key, &toml::node::is_table, "a table");
    if (!node) return std::nullopt;
    return TableReader(*node->as_table(), mContext, prefix);
}

std::vector<const toml::table*> TableReader::tableArray(std::string_view key) {
    const toml::node* node = find(key);
    std::vector<const toml::table*> tables;
    if (!node) return tables;
    const std::string what = "must be an array of tables ([[" + std::string(key) + "]])";
    if (!node->is_array_of_tables()) fail(*node, key, what + ", got " + typeName(*node));
    for (const toml::node& item : *node->as_array()) tables.push_back(item.as_table());
    return tables;
}

void TableReader::notApplicable(std::string_view key, const std::string& why) {
    mAsked.emplace(key);
    const auto it = mTable.find(key);
    if (it != mTable.end()) failAtKey(it->first, "does not apply to " + why);
}

void TableReader::finish() const {
    // toml++ keeps keys sorted; report the unknown key that comes first in the file.
    const toml::key* first = nullptr;
    const toml::node* firstNode = nullptr;
    for (const auto& [key, node] : mTable) {
        if (mAsked.count(key.str())) continue;
        const auto& at = key.source().begin;
        if (!first ||
            std::make_pair(at.line, at.column) <
                std::make_pair(first->source().begin.line, first->source().begin.column)) {
            first = &key;
            firstNode = &node;
        }
    }
    if (!first) {
        if (mContext.keysRead && !mSection.empty())
            (*mContext.keysRead)[mSection].insert(mAsked.begin(), mAsked.end());
        return;
    }
    const bool isTable = firstNode->is_table() || firstNode->is_array_of_tables();
    failAtKey(*first,
              (isTable ? "unknown table" : "unknown key") + suggestion(first->str(), mAsked));
}

void TableReader::failAtKey(const toml::key& key, const std::string& message) const {
    // Errors about a key itself point at the key, not at its value.
    throw SceneError(locOf(key.source()), keyName(key.str()), message);
}

} // namespace firn::scene
