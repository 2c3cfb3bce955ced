// firn_fuzz_replay TARGET PATH...: feeds every file under each PATH (a file or a folder, read
// recursively, in name order) to the fuzz target TARGET ("scene" or "dem"), as libFuzzer would.
// Built with ASan and UBSan, it is how CTest replays the seed corpus and the regressions.
#include "fuzz.h"

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    using Target = int (*)(const std::uint8_t*, std::size_t);
    Target target = nullptr;
    if (argc >= 2 && std::strcmp(argv[1], "scene") == 0) target = firn::fuzz::scene;
    if (argc >= 2 && std::strcmp(argv[1], "dem") == 0) target = firn::fuzz::dem;
    if (!target || argc < 3) {
        std::fprintf(stderr, "usage: firn_fuzz_replay scene|dem PATH...\n");
        return 2;
    }
    std::vector<fs::path> files;
    for (int i = 2; i < argc; ++i) {
        const fs::path path(argv[i]);
        if (fs::is_directory(path)) {
            for (const auto& entry : fs::recursive_directory_iterator(path))
                if (entry.is_regular_file()) files.push_back(entry.path());
        } else if (fs::is_regular_file(path)) {
            files.push_back(path);
        } else {
            // A regressions folder with no file yet is not in git: not an error.
            std::fprintf(stderr, "firn_fuzz_replay: skipped (absent): %s\n", argv[i]);
        }
    }
    if (files.empty()) {
        std::fprintf(stderr, "firn_fuzz_replay: no input found\n");
        return 2;
    }
    std::sort(files.begin(), files.end());
    for (const fs::path& file : files) {
        std::ifstream in(file, std::ios::binary);
        const std::vector<char> bytes{std::istreambuf_iterator<char>(in),
                                      std::istreambuf_iterator<char>()};
        std::fprintf(stderr, "%s\n", file.c_str());
        target(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
    }
    std::printf("firn_fuzz_replay %s: %zu inputs, no finding\n", argv[1], files.size());
    return 0;
}
