// Tolerances of `firn compare`: the defaults in one place, and the --tolerance syntax.
#include <firn/compare.h>

#include <cmath>
#include <stdexcept>

namespace firn {

ToleranceTable ToleranceTable::defaults() {
    ToleranceTable t;
    t.fallback = {0.01, false}; // 1 % of the value, or of a curve's peak
    // Mass is conserved by construction: any change is a change of the method.
    for (const char* name : {"mass", "mass_initial", "mass_final"}) t.byName[name] = {1e-6, false};
    // Frames are written at fixed times; a shift is a change of the output schedule.
    t.byName["time"] = {1e-9, false};
    // Crack speeds are differences of tip positions between frames: a tip one cell further
    // at one frame moves them by dx / frame interval.
    for (const char* name : {"crack_speed", "max_crack_speed", "mean_crack_speed"})
        t.byName[name] = {0.05, false};
    // The drift is a small difference of large energies; 5 % of its own peak.
    t.byName["energy_drift"] = {0.05, false};
    t.byName["alpha_angle_deg"] = {0.5, true}; // degrees
    // Share of the pixels of a rendered frame that may differ (by more than kPixelThreshold).
    t.byName["pixels"] = {0.01, false};
    return t;
}

const Tolerance& ToleranceTable::lookup(const std::string& name) const {
    const auto it = byName.find(name);
    return it == byName.end() ? fallback : it->second;
}

void ToleranceTable::set(const std::string& spec) {
    const std::size_t eq = spec.find('=');
    const std::string name = spec.substr(0, eq);
    if (eq == std::string::npos || name.empty()) {
        throw std::invalid_argument("--tolerance takes name=value (relative, e.g. max_speed=0.05) "
                                    "or name=abs:value (absolute, in the figure's unit); got '" +
                                    spec + "'");
    }
    std::string text = spec.substr(eq + 1);
    Tolerance tolerance;
    if (text.rfind("abs:", 0) == 0) {
        tolerance.absolute = true;
        text = text.substr(4);
    }
    std::size_t used = 0;
    try {
        tolerance.value = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != text.size() || !std::isfinite(tolerance.value) ||
        tolerance.value < 0) {
        throw std::invalid_argument("--tolerance " + name +
                                    ": the value must be a number >= 0, got '" + text + "'");
    }
    if (name == "all") {
        // Every figure, the defaults included: "all" then "name=" refines one of them.
        byName.clear();
        fallback = tolerance;
    } else {
        byName[name] = tolerance;
    }
}

} // namespace firn
