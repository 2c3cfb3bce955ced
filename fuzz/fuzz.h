// The fuzz targets' entry points, shared by the libFuzzer executables (one per target, each with
// its LLVMFuzzerTestOneInput) and by firn_fuzz_replay, which links both and feeds them the corpus.
#pragma once

#include <cstddef>
#include <cstdint>

namespace firn::fuzz {

/// A scene: TOML text, then optionally a line "#--set" and one --set override per line.
int scene(const std::uint8_t* data, std::size_t size);
/// An ESRI ASCII grid, read as Heightfield::parseEsriAscii and sampled as the collider does.
int dem(const std::uint8_t* data, std::size_t size);

} // namespace firn::fuzz

// The libFuzzer executables build with FIRN_FUZZ_ENTRY defined; the replay without.
#ifdef FIRN_FUZZ_ENTRY
#define FIRN_FUZZ_TARGET(function)                                                                 \
    extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {            \
        return function(data, size);                                                               \
    }
#else
#define FIRN_FUZZ_TARGET(function)
#endif
