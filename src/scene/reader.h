// TableReader: typed, range-checked reads from one TOML table of a scene, with errors that name
// file, line, column and key. Every key it is asked for is remembered, so finish() can report
// whatever the file holds that nobody read: nothing in a scene is silently ignored.
#pragma once

#include <firn/errors.h>
#include <firn/scene.h>

#include <toml++/toml.h>

#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace firn::scene {

/// The keys each scene table's readers asked for: "grid" -> {"dx", "cfl", ...}.
using KeyLog = std::map<std::string, std::set<std::string>, std::less<>>;

/// What every reader of one scene shares.
struct SceneContext {
    std::string file;           ///< the scene path, as given, for messages
    std::string folder;         ///< the scene's folder, against which relative files are resolved
    int dimension = 3;          ///< known once [simulation] has been read
    KeyLog* keysRead = nullptr; ///< when set, finish() adds the keys asked for (sceneKeysRead)
};

/// An interval of accepted numbers; infinite bounds are left out of messages.
struct Range {
    double lo = -std::numeric_limits<double>::infinity();
    double hi = std::numeric_limits<double>::infinity();
    bool loOpen = false;
    bool hiOpen = false;

    static Range any() { return {}; }
    static Range positive() { return {0.0, any().hi, true, false}; }
    static Range nonNegative() { return {0.0, any().hi, false, false}; }
    static Range closed(double lo, double hi) { return {lo, hi, false, false}; }
    static Range open(double lo, double hi) { return {lo, hi, true, true}; }
    static Range closedOpen(double lo, double hi) { return {lo, hi, false, true}; }
    static Range openClosed(double lo, double hi) { return {lo, hi, true, false}; }

    bool contains(double v) const;
    /// "> 0", ">= 0" or "in [0, 0.5)".
    std::string describe() const;
};

/// One spelling of an enumerator, for tables that map scene words to enums and back.
template <typename E> struct Named {
    const char* name;
    E value;
};

template <typename E, std::size_t N> const char* nameOf(E value, const Named<E> (&names)[N]) {
    for (const auto& n : names) {
        if (n.value == value) return n.name;
    }
    return "?";
}

/// Shortest text that reads back as the same number in a message ("0.7", "1e+06").
std::string formatNumber(double value);

/// Reads the keys of one table. `prefix` is prepended to key names in messages: "grid." for a
/// plain table, "body 2: " for an entry of an array of tables, "" for the document root.
class TableReader {
public:
    TableReader(const toml::table& table, const SceneContext& context, std::string prefix);

    const SceneContext& context() const { return mContext; }
    const toml::table& table() const { return mTable; }
    /// The prefix without its separator: "grid", "body 2"; for errors about the whole entity.
    std::string label() const;
    std::string keyName(std::string_view key) const { return mPrefix + std::string(key); }

    /// Where the table starts (its header); values set by --set have no line and read "--set".
    SourceLoc headerLoc() const { return locOf(mTable); }
    SourceLoc locOf(const toml::node& node) const { return locOf(node.source()); }
    SourceLoc locOf(const toml::source_region& region) const;
    [[noreturn]] void fail(const toml::node& node, std::string_view key,
                           const std::string& message) const;
    /// Fails at the value of `key`, which must be present: "grid.dx: <message>".
    [[noreturn]] void failAt(std::string_view key, const std::string& message) const;
    /// Fails at the value of `key` with a message about the whole entry, as for a reference that
    /// does not resolve: "body 2: material \"x\" is not defined (...)".
    [[noreturn]] void failReference(std::string_view key, const std::string& message) const;

    bool has(std::string_view key) const { return mTable.contains(key); }
    /// The node of `key` or null; the key counts as read from now on.
    const toml::node* find(std::string_view key);
    /// Fails at the table header for the first key of `keys` that is absent.
    void require(std::initializer_list<const char*> keys, const std::string& forWhat = "");

    // Typed reads: each leaves `out` alone and returns false when the key is absent, and fails
    // with a message naming the key when the value has the wrong type or is out of range.
    bool real(std::string_view key, double& out, const Range& range = Range::any());
    bool integer(std::string_view key, std::int64_t& out, const Range& range);
    template <typename Int> bool integer(std::string_view key, Int& out, const Range& range) {
        std::int64_t value = 0;
        if (!integer(key, value, range)) return false;
        out = static_cast<Int>(value);
        return true;
    }
    bool boolean(std::string_view key, bool& out);
    bool string(std::string_view key, std::string& out); ///< non-empty
    /// A point or direction with exactly `dimension` components; z is 0 in 2D.
    bool vector(std::string_view key, Vec3d& out);
    /// [a, b] with a < b.
    bool interval(std::string_view key, std::array<double, 2>& out);
    /// [[x, y], ...], at least two points, x strictly increasing; `yName` names the second
    /// coordinate in messages ("thickness": "must be an array [x, thickness]").
    bool polyline(std::string_view key, std::vector<std::array<double, 2>>& out,
                  const std::string& yName = "y");
    /// A list of distinct strings, each one of `allowed`.
    bool stringList(std::string_view key, std::vector<std::string>& out,
                    const std::vector<std::string>& allowed);
    template <typename E, std::size_t N>
    bool choice(std::string_view key, E& out, const Named<E> (&names)[N]) {
        std::vector<std::string> words;
        for (const auto& n : names) words.emplace_back(n.name);
        const int index = pick(key, words);
        if (index < 0) return false;
        out = names[index].value;
        return true;
    }

    /// A table value (plain or inline) as a reader of its own; nullopt when absent.
    std::optional<TableReader> subTable(std::string_view key, const std::string& prefix);
    /// The tables of an [[array]]; empty when absent.
    std::vector<const toml::table*> tableArray(std::string_view key);

    /// Fails if `key` is present: it is a known key that `why` (model "snow") does not use.
    void notApplicable(std::string_view key, const std::string& why);
    /// Fails at the first key, in file order, that nothing asked for; then adds the keys asked
    /// for to the context's keysRead under `section` (logKeysAs), when both are set.
    void finish() const;
    /// The scene table this reader reads ("grid", "material"), for sceneKeysRead.
    void logKeysAs(std::string section) { mSection = std::move(section); }

private:
    [[noreturn]] void failAtKey(const toml::key& key, const std::string& message) const;
    using TypeTest = bool (toml::node::*)() const noexcept;
    /// find(key), failing "must be <what>, got <type>" unless the node passes `isType`.
    const toml::node* typed(std::string_view key, TypeTest isType, const char* what);
    double number(const toml::node& node, std::string_view key, const std::string& what) const;
    int pick(std::string_view key, const std::vector<std::string>& words);

    const toml::table& mTable;
    const SceneContext& mContext;
    std::string mPrefix;
    std::string mSection;
    std::set<std::string, std::less<>> mAsked;
};

} // namespace firn::scene
