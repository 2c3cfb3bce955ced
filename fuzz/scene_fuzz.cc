// Fuzz target: the scene reader (firn::parseScene), TOML text and --set overrides.
//
// Input: the scene text, optionally followed by a line "#--set" and then one override
// `key=value` per line (empty lines skipped). A SceneError (or another FirnError) is the expected
// answer to bad input; anything else escaping, a crash, a sanitizer report, a hang or huge memory
// is a finding. A scene that is accepted must be accepted again from its resolved TOML (what a
// run writes to out/<name>/scene.toml and render/report read back), which resolves to itself.
#include "fuzz.h"

#include <firn/errors.h>
#include <firn/scene.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace firn::fuzz {
namespace {

const char* const kPath = "fuzz/scene.toml";
const std::string kMarker = "#--set";

// Splits the input into the scene text and its overrides.
void split(const std::string& input, std::string& text, std::vector<std::string>& overrides) {
    std::size_t marker = input.compare(0, kMarker.size(), kMarker) == 0 ? 0 : std::string::npos;
    if (marker == std::string::npos) {
        const std::size_t at = input.find("\n" + kMarker);
        if (at != std::string::npos) marker = at + 1;
    }
    text = input.substr(0, marker);
    if (marker == std::string::npos) return;
    std::size_t start = input.find('\n', marker);
    while (start != std::string::npos) {
        const std::size_t end = input.find('\n', start + 1);
        std::string line =
            input.substr(start + 1, end == std::string::npos ? std::string::npos : end - start - 1);
        if (!line.empty()) overrides.push_back(std::move(line));
        start = end;
    }
}

} // namespace

int scene(const std::uint8_t* data, std::size_t size) {
    std::string text;
    std::vector<std::string> overrides;
    split(std::string(reinterpret_cast<const char*>(data), size), text, overrides);
    SceneDesc desc;
    try {
        desc = parseScene(text, kPath, overrides);
    } catch (const FirnError&) {
        return 0; // SceneError: the expected answer to bad input
    }
    SceneDesc again;
    try {
        again = parseScene(desc.resolvedToml, kPath, {});
    } catch (const FirnError& e) {
        std::fprintf(stderr,
                     "accepted scene rejected from its resolved TOML: %s\n--- resolved:\n%s",
                     e.what(), desc.resolvedToml.c_str());
        std::abort();
    }
    if (again.resolvedToml != desc.resolvedToml) {
        std::fprintf(stderr,
                     "the resolved TOML changes when read back\n--- resolved:\n%s\n--- read "
                     "back and resolved:\n%s",
                     desc.resolvedToml.c_str(), again.resolvedToml.c_str());
        std::abort();
    }
    return 0;
}

} // namespace firn::fuzz

FIRN_FUZZ_TARGET(firn::fuzz::scene)
