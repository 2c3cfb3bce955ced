// The manual cannot drift from the code: its scene-reference tables are the ones `firn keys
// --markdown` prints, and those list exactly the keys the parser reads.
#include <firn/output_keys.h>
#include <firn/scene_keys.h>

#include "firn_test_paths.h"

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <utility>
#include <vector>

using namespace firn;

namespace {

std::string readText(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    REQUIRE(in);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

const std::filesystem::path kSource = FIRN_SOURCE_DIR;

// The text on `page` between the begin and end lines of the generated table `table`; found is
// false when the page has no such table.
std::string tableOnPage(const std::string& page, const std::string& table, bool& found) {
    const std::string begin = keyTableBegin(table) + "\n";
    const std::size_t at = page.find(begin);
    found = at != std::string::npos;
    if (!found) return "";
    const std::size_t from = at + begin.size();
    const std::size_t to = page.find(std::string("\n") + kKeyTableEnd, from);
    return page.substr(from, to == std::string::npos ? std::string::npos : to - from);
}

std::size_t generatedTables(const std::string& page) {
    std::size_t tables = 0;
    for (std::size_t at = page.find("<!-- firn keys"); at != std::string::npos;
         at = page.find("<!-- firn keys", at + 1))
        ++tables;
    return tables;
}

// Every generated table of the page at docs/`relative` equals the code's, and the page has no
// other generated table.
void checkGeneratedTables(const std::string& relative,
                          const std::vector<std::pair<std::string, std::string>>& tables) {
    const std::string page = readText(kSource / "docs" / relative);
    for (const auto& [name, table] : tables) {
        INFO("docs/" << relative << ", table [" << name
                     << "]: run tests/docs/update_key_tables.py");
        bool found = false;
        const std::string onPage = tableOnPage(page, name, found);
        REQUIRE(found);
        CHECK(onPage == table);
    }
    CHECK(generatedTables(page) == tables.size()); // none the code does not know
}

} // namespace

TEST_CASE("The manual's scene reference holds the tables firn keys prints", "[docs]") {
    std::vector<std::pair<std::string, std::string>> tables;
    for (const std::string& section : sceneKeySections())
        tables.emplace_back(section, sceneKeyTable(section));
    checkGeneratedTables("reference/scene.md", tables);
}

TEST_CASE("The manual's outputs reference holds the tables firn keys prints", "[docs]") {
    checkGeneratedTables("reference/outputs.md",
                         {{"metrics.csv", outputKeyTable("metrics.csv")},
                          {"summary.json", outputKeyTable("summary.json")}});
}

TEST_CASE("The outputs reference documents exactly the summary keys the run writes", "[docs]") {
    // metrics.csv takes its header from metricColumnDocs(), so its columns cannot drift; the
    // summary's keys are set one by one in src/cli/run.cc: every literal key set on the
    // summary object (`j.set("key", ...)`, `j.setBool(...)`, the overload box's names).
    const std::string source = readText(kSource / "src" / "cli" / "run.cc");
    std::set<std::string> written;
    const std::regex set(R"re(\bj\.set(?:Bool)?\("([a-z_0-9]+)")re");
    for (auto it = std::sregex_iterator(source.begin(), source.end(), set);
         it != std::sregex_iterator(); ++it)
        written.insert((*it)[1]);
    const std::regex box(R"re("(settle_overloaded_[xyz]_m(?:in|ax))")re");
    for (auto it = std::sregex_iterator(source.begin(), source.end(), box);
         it != std::sregex_iterator(); ++it)
        written.insert((*it)[1]);
    std::set<std::string> documented;
    for (const OutputKeyDoc& doc : summaryKeyDocs()) documented.insert(doc.name);
    REQUIRE(written.size() > 40); // the scan found the writer
    for (const std::string& key : written) {
        INFO(key << " is written to summary.json but not in summaryKeyDocs()");
        CHECK(documented.count(key) == 1);
    }
    for (const std::string& key : documented) {
        INFO(key << " is documented in summaryKeyDocs() but src/cli/run.cc does not write it");
        CHECK(written.count(key) == 1);
    }
}

TEST_CASE("The scene reference documents exactly the keys the parser reads", "[docs]") {
    // Every shipped, bench and tutorial scene: together they reach every table, model and shape.
    std::map<std::string, std::set<std::string>> read;
    for (const char* folder : {"scenes", "bench", "docs/tutorials"}) {
        if (!std::filesystem::exists(kSource / folder)) continue;
        for (const auto& entry : std::filesystem::directory_iterator(kSource / folder)) {
            if (entry.path().extension() != ".toml") continue;
            INFO(entry.path().string());
            for (const auto& [section, keys] : sceneKeysRead(entry.path().string()))
                read[section].insert(keys.begin(), keys.end());
        }
    }
    std::map<std::string, std::set<std::string>> documented;
    for (const SceneKeyDoc& doc : sceneKeyDocs())
        for (const std::string& key : keyNames(doc)) documented[doc.section].insert(key);
    for (const auto& [section, keys] : documented) {
        for (const std::string& key : keys) {
            INFO("[" << section << "] " << key
                     << " is documented but no scene under scenes/, bench/ or docs/tutorials/ "
                        "makes the parser read it (a key the parser lost, or a scene missing)");
            CHECK(read[section].count(key) == 1);
        }
    }
    for (const auto& [section, keys] : read) {
        for (const std::string& key : keys) {
            INFO("[" << section << "] " << key
                     << " is read by the parser but missing from the scene reference "
                        "(src/scene/key_docs.cc, then docs/reference/scene.md)");
            CHECK(documented[section].count(key) == 1);
        }
    }
}
