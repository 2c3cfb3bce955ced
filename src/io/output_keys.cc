// The columns of metrics.csv and the keys of summary.json, documented where the writers take
// them from (firn/output_keys.h). outputs.md is the contract; "Firn addition" marks the rest.
#include <firn/output_keys.h>

#include <sstream>

namespace firn {
namespace {

const std::vector<OutputKeyDoc> kMetricColumns = {
    {"frame", "", "frame number, 0 the initial (settled) state"},
    {"time", "s", "simulated time"},
    {"steps", "", "time steps taken so far"},
    {"dt", "s", "the last step's size"},
    {"particles", "", "particles in the run"},
    {"active_voxels", "", "active grid nodes"},
    {"mass", "kg (2D: kg/m)", "total particle mass"},
    {"com_x", "m", "centre of mass"},
    {"com_y", "m", "centre of mass"},
    {"com_z", "m", "centre of mass (0 in 2D)"},
    {"momentum_x", "kg m/s", "total linear momentum"},
    {"momentum_y", "kg m/s", "total linear momentum"},
    {"momentum_z", "kg m/s", "total linear momentum (0 in 2D)"},
    {"kinetic_energy", "J (2D: J/m)", "of the particles"},
    {"max_speed", "m/s", "the largest particle speed"},
    {"front_x", "m", "the largest x reached by moving snow (faster than 0.1 m/s since t = 0)"},
    {"crack_tip_x", "m",
     "the crack's leading end along x, as far as it has grown into layer that had not cracked; "
     "empty without a weak layer"},
    {"crack_speed", "m/s", "d(`crack_tip_x`)/dt between frames"},
    {"failed_fraction", "", "share of the particles that have yielded at least once"},
    {"wall_seconds", "s", "wall time since the run (or the resumed run) started"},
    {"elastic_energy", "J (2D: J/m)", "stored elastic energy (Firn addition)"},
    {"gravitational_energy", "J (2D: J/m)", "potential energy, m g y (Firn addition)"},
    {"energy_drift", "J (2D: J/m)",
     "total energy minus its initial value: dissipation shows as a negative drift (Firn "
     "addition)"},
    {"crack_tip_min_x", "m",
     "the crack's extent: the largest run of dx cells along x holding weak-layer particles with "
     "η > 0, gaps of up to 3 cells bridged (Firn addition)"},
    {"crack_tip_max_x", "m", "the other end of that extent (Firn addition)"},
    {"asleep", "", "particles asleep (`grid.sleep`; Firn addition)"},
    {"slab_fractures", "", "slab fractures through the slab so far"},
    {"slab_fractured_fraction", "", "fractured share of the slab mass"},
    {"slab_blocks", "", "intact slab blocks (face-connected dx cells of unfractured slab)"},
    {"largest_block_mass", "kg (2D: kg/m)", "the largest block; empty without a block"},
    {"median_block_mass", "kg (2D: kg/m)", "the median block; empty without a block"},
    {"outflow_mass", "kg (2D: kg/m)", "mass that left `simulation.domain_min`/`domain_max` so far"},
    {"slab_speed", "m/s",
     "speed of the slab's centre of mass (the `snow` materials of layers on a weak layer); empty "
     "without a slab (Firn addition)"},
    {"collapse_min_x", "m",
     "the extent of the weak layer whose cohesion is gone (p0 = 0), by the crack extent's rule; "
     "empty while none (Firn addition)"},
    {"collapse_max_x", "m", "the other end of that extent (Firn addition)"},
};

const std::vector<OutputKeyDoc> kSummaryKeys = {
    {"scene", "", "the scene file as given"},
    {"dimension", "", "2 or 3"},
    {"particles", "", "particles at the end"},
    {"steps", "", "time steps after settling"},
    {"frames", "", "frames written"},
    {"end_time", "s", "simulated time reached (when it stopped, with `stop_reason` `at_rest`)"},
    {"wall_seconds", "s", "wall time of this process"},
    {"threads", "", "worker threads"},
    {"particle_steps_per_second", "",
     "particles × steps of this process over its wall time (settling and output included)"},
    {"peak_rss_bytes", "bytes", "the process's peak resident memory"},
    {"baseline_rss_bytes", "bytes", "resident memory before the world was built"},
    {"bytes_per_particle", "bytes",
     "(`peak_rss_bytes` − `baseline_rss_bytes`) / `particles`: what the run adds per particle"},
    {"mass_initial", "kg (2D: kg/m)", "total mass at frame 0"},
    {"mass_final", "kg (2D: kg/m)", "total mass at the end"},
    {"mass_outflow", "kg (2D: kg/m)",
     "mass that left the domain: `mass_initial` = `mass_final` + `mass_outflow`"},
    {"max_speed", "m/s", "the largest particle speed of any frame"},
    {"max_crack_speed", "m/s", "the largest `crack_speed` of any frame"},
    {"mean_crack_speed", "m/s",
     "the middle 80 % of the crack's travel over the time it took to pass it (from 10 % to 90 % "
     "of the travel, interpolated between frames): a start and a stop do not weigh in"},
    {"crack_propagation_distance", "m", "how far the crack tip ran (Firn addition)"},
    {"crack_tip_steps", "",
     "`[{time, x}, ...]`: the crack's leading end timed to the step, at each step it moved "
     "(`[]` without a crack; Firn addition)"},
    {"slab_fracture_count", "", "slab fractures through the slab"},
    {"first_slab_fracture_time", "s", "null when none"},
    {"slab_fractures", "",
     "`[{x, y, z, time, start_depth_fraction, distance_behind_crack_tip, start_time, "
     "distance_behind_crack_tip_at_start}, ...]`, in the order they went through (Slab "
     "fractures, below)"},
    {"final_slab_blocks", "", "intact slab blocks at the end"},
    {"max_slab_blocks", "", "the most blocks of any frame"},
    {"final_largest_block_mass", "kg (2D: kg/m)", "null without a block"},
    {"runout_x", "m", "the largest x of snow that moved (faster than 0.1 m/s since t = 0)"},
    {"runout_y", "m", "the height of that farthest point"},
    {"release_top_x", "m", "the highest point moving snow has had (the crown)"},
    {"release_top_y", "m", "its height"},
    {"alpha_angle_deg", "degrees",
     "the runout angle (Lied and Bakkehøi 1980): the drop from the release's top to the runout "
     "point over the horizontal distance between them. On a DEM that distance is measured along "
     "the path (`runout_length`, `path_source`) and the runout point ends the ppr ≥ "
     "`runout_pressure_threshold` footprint; elsewhere along x, from (`release_top_x`, "
     "`release_top_y`) to (`runout_x`, `runout_y`); null when nothing moved"},
    {"runout_length", "m",
     "on a DEM: horizontal distance along the path from the release's top to the runout point "
     "(null when no cell reached the threshold)"},
    {"runout_point", "m", "on a DEM: `[x, y, z]` of the runout point, a raster cell's centre"},
    {"runout_pressure_threshold", "kPa", "on a DEM: `output.runout_pressure`"},
    {"path_source", "",
     "on a DEM: `scene` (`output.path`) or `derived` (the centre of mass's track)"},
    {"com_path_length", "m", "horizontal length of the centre of mass's path"},
    {"com_travel_angle_deg", "degrees", "the centre of mass's drop over that path"},
    {"rasters", "", "the peak rasters' folder (on a heightfield; Firn addition)"},
    {"raster_samples", "", "how many times the peak fields were sampled"},
    {"raster_wall_seconds", "s", "wall time spent sampling them"},
    {"settle", "", "true when the scene settled before t = 0"},
    {"settle_converged", "", "false when not at rest by `settle_max_time`"},
    {"settle_time", "s", "simulated settling time"},
    {"settle_steps", "", "settling steps"},
    {"settle_cfl", "", "the CFL number settling stepped at"},
    {"settle_wall_seconds", "s", "wall time of settling"},
    {"settle_overloaded_particles", "",
     "particles whose settled static load exceeds their strength (they yield at t = 0)"},
    {"settle_overloaded_x_min", "m", "the overloaded particles' box (when there are any)"},
    {"settle_overloaded_x_max", "m", "the overloaded particles' box"},
    {"settle_overloaded_y_min", "m", "the overloaded particles' box"},
    {"settle_overloaded_y_max", "m", "the overloaded particles' box"},
    {"settle_overloaded_z_min", "m", "the overloaded particles' box (3D)"},
    {"settle_overloaded_z_max", "m", "the overloaded particles' box (3D)"},
    {"settle_overloaded_by_material", "",
     "`[{\"material\": \"weak\", \"particles\": 517}, ...]`, by the materials' scene names"},
    {"settle_message", "", "what settling found, when there is something to say"},
    {"status", "", "`ok`, `unstable`, `interrupted` or `io_error`"},
    {"message", "", "why the run stopped, when it did not end ok"},
    {"stop_reason", "",
     "`end_time` (it ran to `simulation.end_time`, or stopped early with `status` not `ok`) or "
     "`at_rest` (`simulation.stop_at_rest`: the flow stopped)"},
    {"rest_energy_ratio", "",
     "the last frame's kinetic energy over the largest of any frame (with `stop_at_rest`)"},
    {"checkpoints_written", "", "by this process"},
    {"checkpoint_wall_seconds", "s", "wall time spent writing them"},
    {"resumed_from_frame", "", "a resumed run's checkpoint frame (only in a resumed run)"},
};

} // namespace

const std::vector<OutputKeyDoc>& metricColumnDocs() {
    return kMetricColumns;
}

const std::vector<OutputKeyDoc>& summaryKeyDocs() {
    return kSummaryKeys;
}

std::vector<std::string> metricColumns() {
    std::vector<std::string> names;
    for (const OutputKeyDoc& doc : kMetricColumns) names.emplace_back(doc.name);
    return names;
}

std::string outputKeyTable(const std::string& file) {
    const std::vector<OutputKeyDoc>& docs = file == "metrics.csv" ? kMetricColumns : kSummaryKeys;
    std::ostringstream out;
    out << "| " << (file == "metrics.csv" ? "column" : "key") << " | unit | meaning |\n"
        << "| --- | --- | --- |";
    for (const OutputKeyDoc& doc : docs)
        out << "\n| `" << doc.name << "` |" << (*doc.unit ? " " : "") << doc.unit << " | "
            << doc.meaning << " |";
    return out.str();
}

} // namespace firn
