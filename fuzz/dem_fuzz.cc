// Fuzz target: the DEM reader (firn::Heightfield::parseEsriAscii, what readEsriAscii runs on a
// file's text).
//
// A SceneError is the expected answer to bad input; anything else escaping, a crash, a sanitizer
// report, a hang or huge memory is a finding. A grid that is accepted is sampled as the terrain
// collider samples it, inside and outside the grid: heights and slopes must be finite.
#include "fuzz.h"

#include <firn/dem.h>
#include <firn/errors.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace firn::fuzz {

int dem(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    Heightfield h;
    try {
        h = Heightfield::parseEsriAscii(text, "fuzz/dem.asc");
    } catch (const FirnError&) {
        return 0; // SceneError: the expected answer to bad input
    }
    if (h.columns() < 2 || h.rows() < 2) {
        std::fprintf(stderr, "accepted a %d x %d grid\n", h.columns(), h.rows());
        std::abort();
    }
    for (float x : {-1e6f, -1.f, 0.f, 0.5f, 3.f, 1e6f})
        for (float z : {-1e6f, -1.f, 0.f, 0.5f, 3.f, 1e6f}) {
            float dhdx = 0.f, dhdz = 0.f;
            const float y = h.heightAt(x, z);
            h.gradientAt(x, z, dhdx, dhdz);
            if (!std::isfinite(y) || !std::isfinite(dhdx) || !std::isfinite(dhdz)) {
                std::fprintf(stderr, "non-finite terrain at (%g, %g): height %g, slope (%g, %g)\n",
                             x, z, y, dhdx, dhdz);
                std::abort();
            }
        }
    return 0;
}

} // namespace firn::fuzz

FIRN_FUZZ_TARGET(firn::fuzz::dem)
