#include "report/run_scene.h"

#include <firn/errors.h>

#include <toml++/toml.h>

#include <fstream>
#include <sstream>

namespace firn::report {

SceneDesc loadRunScene(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) {
        throw IoError("cannot read " + path +
                      ": no such file (is this a folder written by "
                      "`firn run`?)");
    }
    std::ostringstream text;
    text << in.rdbuf();
    toml::table root;
    try {
        root = toml::parse(text.str(), std::string_view(path));
    } catch (const toml::parse_error& e) {
        const auto& at = e.source().begin;
        throw SceneError(SourceLoc{path, int(at.line), int(at.column)}, "syntax",
                         std::string(e.description()));
    }
    root.erase("terrain");
    root.erase("body");
    root.erase("cut");
    if (toml::table* output = root["output"].as_table()) {
        output->erase("rasters");
        output->erase("path");
    }
    std::ostringstream withoutTerrain;
    withoutTerrain << root;
    return parseScene(withoutTerrain.str(), path);
}

} // namespace firn::report
