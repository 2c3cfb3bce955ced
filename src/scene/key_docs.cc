// The scene keys' documentation: one entry per row of the manual's scene reference
// (docs/reference/scene.md), next to the parser that reads them, so that the page cannot drift
// from the code. `firn keys --markdown` prints the tables; tests/docs_test.cc fails when the
// page differs from them or when the parser reads a key that has no entry here (or the reverse).
#include <firn/scene_keys.h>

#include <iterator>
#include <sstream>

namespace firn {
namespace {

// Each field is Markdown, as it appears in the table: keys in backticks (several when they go
// together), the default, the models a material key applies to, what the key means.
const SceneKeyDoc
    kSceneKeyDocs[] =
        {
            // [simulation]
            {"simulation", R"md(`name`)md", R"md(`"scene"`)md", "",
             R"md(run name; default output folder `out/<name>`)md"},
            {"simulation", R"md(`dimension`)md", R"md(`3`)md", "", R"md(2 (plane strain) or 3)md"},
            {"simulation", R"md(`end_time`)md", R"md(`1.0`)md", "",
             R"md(simulated time, s (> 0))md"},
            {"simulation", R"md(`frame_rate`)md", R"md(`24`)md", "",
             R"md(output frames per simulated second (> 0))md"},
            {"simulation", R"md(`gravity`)md", R"md(`[0, -9.81, 0]`)md", "", R"md(m/s²)md"},
            {"simulation", R"md(`seed`)md", R"md(`1`)md", "",
             R"md(every random choice (particle jitter) derives from it)md"},
            {"simulation", R"md(`settle`)md", R"md(`true`)md", "",
             R"md(start at rest: before t = 0 the scene settles under full gravity into static equilibrium (see *Starting at rest* below). Off when `gravity_ramp` > 0 is given; `settle = true` with a ramp is an error (Firn addition))md"},
            {"simulation", R"md(`settle_max_time`)md", R"md(`2.0`)md", "",
             R"md(s of simulated settling at most (> 0); a scene not at rest by then starts anyway, with a warning and `settle_converged: false`)md"},
            {"simulation", R"md(`settle_tolerance`)md", R"md(`1e-6`)md", "",
             R"md(settled when a peak of the kinetic energy falls below this fraction of the elastic energy (> 0))md"},
            {"simulation", R"md(`settle_cfl`)md", R"md(`0.7`)md", "",
             R"md(the CFL number of the settling steps (in (0, 10]); by default 0.7, or `grid.cfl` when that is larger: the largest number the stability study measured stable for APIC at every particle density (`bench/results/stability/`; 1.0 only at two or more particles per cell along each axis, and a granular box settling at 1.0 went unstable). The settled state hardly depends on it (3 % of the settling displacement between 0.4 and 0.7, `firn_tests "Settling steps at its own*"`); a scene whose settling goes unstable says so and names this key (Firn addition))md"},
            {"simulation", R"md(`stop_at_rest`)md", R"md(`true`)md", "",
             R"md(end the run once the avalanche has stopped: after the centre of mass has travelled one cell, the first frame whose kinetic energy is below `rest_energy_fraction` of the largest so far ends it, as AvaFrame's `stopCrit` does. `summary.json` says `stop_reason` (`"at_rest"` or `"end_time"`) and `end_time` is then when it stopped; the last frame, the rasters and the summary are written as at the end time. A scene that never moves (a stable slope) runs to `end_time`. Set `false` for a run of fixed length (hazard-run key with its name fixed by the spec))md"},
            {"simulation", R"md(`rest_energy_fraction`)md", R"md(`0.01`)md", "",
             R"md(in (0, 1): "stopped" means a frame's kinetic energy below this fraction of its peak over the frames (AvaFrame's `stopCrit`, 1 %); only with `stop_at_rest = true`)md"},
            {"simulation", R"md(`domain_min`, `domain_max`)md", R"md(unbounded)md", "",
             R"md(m; the simulated region (give both). Snow that leaves it — off the edge of a DEM, past the end of a path, falling forever — is removed at the end of the frame and counted as outflow (`outflow_mass` in metrics.csv, `mass_outflow` in summary.json; `mass_initial` = `mass_final` + `mass_outflow`). Without a domain nothing is removed: a heightfield continues its edge heights, a plane and a profile's end segments go on, so snow slides on rather than falling (Firn addition))md"},
            {"simulation", R"md(`gravity_ramp`)md", R"md(`0.0`)md", "",
             R"md(s; the older way to start: gravity grows linearly from 0 over this time (no settling stage) so that bodies seeded stress-free load gradually; they still ring a little (Firn addition))md"},
            // [grid]
            {"grid", R"md(`dx`)md", R"md(`0.05`)md", "", R"md(grid spacing, m)md"},
            {"grid", R"md(`particles_per_cell`)md", R"md(`8`)md", "",
             R"md(particles seeded per cell, 1–64 (2D: per square cell). A perfect square/cube is seeded on a jittered sub-lattice, other counts uniformly at random in the cell.)md"},
            {"grid", R"md(`transfer`)md", R"md(`"apic"`)md", "",
             R"md(`"apic"`, `"pic"`, `"flip"` or `"xpic"` (Firn addition). APIC and PIC average the particles' velocities over the kernel (three cells) at every transfer, a numerical viscosity of order dx²/dt: harmless in a thick flow, but across a weak layer only a few cells thick it holds a released slab back ([*Slope-scale runs*](../slope-scale.md)); the slope scenes use `"flip"` with `flip_relaxation_time = 1`)md"},
            {"grid", R"md(`flip_blend`)md", R"md(`0.95`)md", "",
             R"md(FLIP fraction of the PIC/FLIP blend (used by `"flip"`); 1 is pure FLIP (no transfer damping; particle velocities keep a noise that the grid velocity, which moves them, does not have). A fixed blend damps once per step, so its damping follows the time step, not time)md"},
            {"grid", R"md(`flip_relaxation_time`)md", R"md(none)md", "",
             R"md(s, > 0, used by `"flip"`, instead of `flip_blend` (Firn addition): each step blends FLIP with the fraction exp(−dt / τ), so the particles' velocity noise relaxes toward the grid's velocity as exp(−t / τ) whatever dt is, and a flow is damped by a rate per second that does not grow with the step count. Giving both keys in a file is an error; a `--set` of one overrides the other in the file. The slope scenes use 1 s ([*Slope-scale runs*](../slope-scale.md)))md"},
            {"grid", R"md(`xpic_order`)md", R"md(`2`)md", "",
             R"md(m of XPIC(m) (Hammerquist & Nairn 2017; used by `"xpic"`; Firn addition), 1–16: the particles' velocity becomes S(v − v^L + v\*) with v\* = Σ_{k<m} (I − S⁺S)^k v^L, S interpolating grid to particles, S⁺ the mass-weighted transfer back and v^L the transferred grid velocity: m − 1 extra round trips through the particles a step. 1 is PIC; as m grows it keeps more of what the grid can carry (PIC's smoothing of it falls from 44 % to 29, 16, 8 % at m = 2, 4, 8 in `firn_tests "*XPIC(m)*"`) and, unlike FLIP, keeps none of the particle noise the grid cannot carry. Not with a slip surface (`slides_on`). Cost and accuracy against the other transfers: [*Performance* → *XPIC*](../performance.md#xpic-a-transfer-between-pic-and-flip-2026-12-05))md"},
            {"grid", R"md(`cfl`)md", R"md(`0.4`)md", "",
             R"md(dt ≤ cfl · dx / (max particle speed + P-wave speed), (0, 10])md"},
            {"grid", R"md(`max_dt`)md", R"md(none)md", "",
             R"md(s, > 0: a cap on the step below the CFL limit. None by default (until 2026-12-06 it was 1e-3 s whatever the scene): the explicit update's stability is the CFL condition's, the contact and friction laws are projections of the nodal velocity and the Voellmy drag is implicit in dt, so none of them limits the step, and the full suite passes at the CFL step ([*Performance* → *Issue 50*](../performance.md#issue-50-speed-on-the-shipped-scenes-2026-12-06-twenty-fifth-session-in-progress)). A coarse DEM scene (dx 2–2.5 m, soft granular snow) then steps at ~2e-2 s instead of 1e-3)md"},
            {"grid", R"md(`jitter`)md", R"md(`0.5`)md", "",
             R"md(fraction of a sub-cell by which lattice seeds are jittered, [0, 1] (Firn addition))md"},
            {"grid", R"md(`sleep`)md", R"md(`true`)md", "",
             R"md(resting snow sleeps: the particles of an 8^d leaf that, with all its neighbour leaves, has stayed slower than `sleep_speed` for `sleep_steps` steps without accelerating (its mean velocity changed by less than 5 % of g over those steps: snow that starts to fail from rest is slow at first) skip G2P and plasticity (they still carry their mass and frozen stress in P2G) until a particle in or next to the leaf moves at `sleep_speed`, or the grid accelerates the frozen snow by more than 5 % of g. Nothing sleeps during `gravity_ramp`. `false` opts out. See `bench/README.md` (sleep study) for what it saves and changes.)md"},
            {"grid", R"md(`sleep_speed`)md", R"md(`0.02`)md", "", R"md(m/s, > 0)md"},
            {"grid", R"md(`sleep_steps`)md", R"md(`100`)md", "", R"md(steps, 1–60000)md"},
            // [material]
            {"material", R"md(`name`)md", R"md(required)md", R"md(all)md",
             R"md(referenced by bodies)md"},
            {"material", R"md(`model`)md", R"md(required)md", "",
             R"md(`"elastic"`, `"snow"`, `"weak_layer"`, `"granular"`)md"},
            {"material", R"md(`density`)md", R"md(`250` (weak_layer: `100`))md", R"md(all)md",
             R"md(kg/m³; for snow and weak_layer also where the snow parameter table is read)md"},
            {"material", R"md(`youngs_modulus`)md", R"md(`1e6`; snow, weak_layer: table)md",
             R"md(all)md", R"md(Pa)md"},
            {"material", R"md(`poisson_ratio`)md", R"md(`0.3`; snow, weak_layer: table)md",
             R"md(all)md", R"md([0, 0.5))md"},
            {"material", R"md(`critical_state_slope`)md", R"md(table)md", R"md(snow, weak_layer)md",
             R"md(M, eq. (1))md"},
            {"material", R"md(`cohesion_ratio`)md", R"md(table)md", R"md(snow, weak_layer)md",
             R"md(β: the isotropic tensile strength is β·p0)md"},
            {"material", R"md(`initial_p0`)md", R"md(table)md", R"md(snow, weak_layer)md",
             R"md(Pa, isotropic compressive strength at rest)md"},
            {"material", R"md(`hardening`)md", R"md(table)md", R"md(snow, weak_layer)md",
             R"md(ξ in p0 = K sinh(ξ max(−ε_V^P, 0)), eq. (2))md"},
            {"material", R"md(`softening`)md", R"md(table)md", R"md(weak_layer)md",
             R"md(α, eq. (4): controls the weak layer's fracture energy)md"},
            {"material", R"md(`softening_length`)md",
             R"md(table (`0.06`))md", R"md(weak_layer)md", R"md(m (≥ 0), Firn addition: the thickness of collapsing layer `softening` was calibrated for. On a grid fine enough that the band a collapse leaves, 6 cells, is thinner (dx < `softening_length`/6), α is scaled by 6 dx / `softening_length` so that the energy a collapse dissipates per unit area stays the same (crack band, [*Snow*](../snow.md) → Resolution); `firn check` prints the α used, and the collapse energy per unit area of each weak-layer body against the calibrated layer's (a layer thicker than `softening_length` on a grid that lets the collapse fill it dissipates more, in proportion: check prints the α that matches; not applied, an explicit α means what it says). `0`: α as given at any dx)md"},
            {"material", R"md(`dynamic_critical_state_slope`)md", R"md(table)md",
             R"md(weak_layer)md", R"md(M_d after full softening, eq. (5))md"},
            {"material", R"md(`friction_angle`)md", R"md(`30`)md", R"md(granular)md",
             R"md(degrees, the Mohr–Coulomb angle in 2D and 3D: a biaxial or simple-shear test mobilises it (2D is plane strain); with μ(I), the angle at rest; the flow is non-dilatant, so sand that flows resists shear along its flow with τ/σ_n = sin φ and stops only on slopes below atan(sin φ) (26.6° for 30°): a pile steeper than that stands until something starts it ([*Known limitations*](../limitations.md), V11))md"},
            {"material", R"md(`dynamic_friction_angle`)md",
             R"md(`friction_angle` (rate-independent))md", R"md(granular)md",
             R"md(degrees, μ(I): the Mohr–Coulomb angle the friction tends to at large inertial number; not below `friction_angle`)md"},
            {"material", R"md(`grain_diameter`)md", R"md(`0.001`)md", R"md(granular)md",
             R"md(m, d in the inertial number (μ(I) only))md"},
            {"material", R"md(`inertial_number_scale`)md", R"md(`0.279`)md", R"md(granular)md",
             R"md(I_0 of μ(I) (Jop et al. 2006, glass beads; μ(I) only))md"},
            // [terrain]
            {"terrain", R"md(`name`)md", "", "",
             R"md(optional, unique: `--set terrain.<name>.friction=0.25` calibrates it from the command line; messages name it)md"},
            {"terrain", R"md(`shape`)md", R"md(required)md", "",
             R"md(`"plane"`, `"profile"`, `"heightfield"`)md"},
            {"terrain", R"md(`point`, `normal`)md", R"md(`[0,0,0]`, `[0,1,0]`)md", "",
             R"md(plane: a point on it and its outward normal (normalised))md"},
            {"terrain", R"md(`points`)md", "", "",
             R"md(profile: `[[x, y], ...]` with x strictly increasing; a ground line y(x), extended past its ends along the end segments, extruded along z in 3D)md"},
            {"terrain", R"md(`file`)md", "", "",
             R"md(heightfield (3D only): a DEM, relative to the scene file: any raster GDAL reads (GeoTIFF, `.asc`, ...; band 1), north-up with square cells (else an error that says how to warp it). `.asc` files go through Firn's own reader, whose errors name the line (any header case, `xllcorner`/`xllcenter`); their CRS comes from a `.prj` beside them. The DEM's easting is x, its northing z, its elevation y; heights at cell centres, bilinear in between, the edge values continued outside. See [*Real terrain*](../terrain.md))md"},
            {"terrain", R"md(`nodata`)md", R"md(`"error"`)md", "",
             R"md(heightfield: NODATA cells (and NaN) are an error naming how many and the first (row 1 in the north), or `"fill"`: each takes the mean of its valid 4-neighbours, filled from the edges of a hole inwards (as `gdal_fillnodata` without smoothing))md"},
            {"terrain", R"md(`boundary`)md", R"md(`"friction"`)md", "",
             R"md(`"friction"` (Coulomb), `"slip"`, `"sticky"` (no slip; the nodes inside mirror the outside, below), `"voellmy"` (Coulomb + turbulent friction, as RAMMS), `"samosat"` (AvaFrame's default basal law, Sampl and Zwinger 2004: τ = τ₀ + μ (1 + R_s⁰ / (R_s⁰ + R_s)) σ_b + ρ u² / (ln(h / R) / κ + B)², R_s = ρ u² / σ_b; the μ σ_b part acts at the ground's grid nodes as Coulomb friction, the rest on the particles over the bed, spread over the flow's depth h; name fixed by the spec))md"},
            {"terrain", R"md(`friction`)md", R"md(`0.4`; `0.155` with `"samosat"`)md", "",
             R"md(Coulomb coefficient μ (with `boundary = "friction"`, `"voellmy"` or `"samosat"`; samosAT's default is AvaFrame's standard calibration))md"},
            {"terrain", R"md(`samosat_tau0`)md", R"md(`0.0`)md", "",
             R"md(samosAT's minimum shear stress τ₀, Pa (≥ 0; only with `boundary = "samosat"`, as the four below; defaults: AvaFrame's standard calibration))md"},
            {"terrain", R"md(`samosat_rs0`)md", R"md(`0.222`)md", "",
             R"md(samosAT's R_s⁰ (> 0): the Coulomb term is 2 μ σ_b at rest and falls to μ σ_b as R_s = ρ u² / σ_b grows past it)md"},
            {"terrain", R"md(`samosat_kappa`)md", R"md(`0.43`)md", "", R"md(samosAT's κ (> 0) of the turbulent term)md"},
            {"terrain", R"md(`samosat_r`)md", R"md(`0.05`)md", "",
             R"md(samosAT's roughness R, m (> 0); ln(h / R) is taken as 0 where the flow is thinner)md"},
            {"terrain", R"md(`samosat_b`)md", R"md(`4.13`)md", "", R"md(samosAT's B (> 0) of the turbulent term)md"},
            {"terrain", R"md(`turbulence`)md", R"md(`2000`)md", "",
             R"md(Voellmy's turbulent friction ξ, m/s² (only with `boundary = "voellmy"`; RAMMS uses 1000–4000 for dense flows, with μ 0.15–0.3))md"},
            // [body]
            {"body", R"md(`material`)md", R"md(required)md", "", R"md(a material name)md"},
            {"body", R"md(`shape`)md", R"md(required)md", "",
             R"md(`"box"`, `"sphere"`, `"layer"`, `"polygon"` (3D: release areas from a GIS file))md"},
            {"body", R"md(`name`)md", "", "",
             R"md(optional; a layer can sit on a named layer, a cut names a layer)md"},
            {"body", R"md(`min`, `max`)md", "", "", R"md(box corners, m)md"},
            {"body", R"md(`center`, `radius`)md", "", "", R"md(sphere, m)md"},
            {"body", R"md(`velocity`)md", R"md(`[0,0,0]`)md", "", R"md(initial velocity, m/s)md"},
            {"body", R"md(`on_top_of`)md", R"md(`"ground"`)md", "",
             R"md(layer: `"ground"` or an earlier layer body's name)md"},
            {"body", R"md(`thickness`)md", "", "", R"md(layer thickness normal to the ground, m; polygon: optional, when given it is every area's thickness (it overrides the file's attribute))md"},
            {"body", R"md(`x_range`, `z_range`)md", "", "",
             R"md(layer extent along x (and z in 3D), m)md"},
            {"body", R"md(`file`)md", "", "",
             R"md(polygon: a vector file of release areas in the DEM's coordinates (shapefile, GeoPackage, GeoJSON: anything OGR reads), relative to the scene; every polygon and multipolygon of every layer is a release area, seeded as a layer on the ground (or `on_top_of`) with its thickness normal to the slope. A vertex outside the DEM is an error that names the feature and the vertex)md"},
            {"body", R"md(`thickness_attribute`)md", R"md(`"thickness"`)md", "",
             R"md(polygon: the attribute that holds each area's release thickness, m (AvaFrame's convention); a feature without it is an error unless `thickness` is given)md"},
            {"body", R"md(`thickness_profile`)md", R"md(none)md", "",
             R"md(layer: `[[x, thickness], ...]` (m), the thickness along x instead of one `thickness` (give one of the two): linear between the points, constant past the ends, x strictly increasing, every thickness > 0; `thickness_noise` multiplies it. For a snowpack deepest mid-path, as on the 3D slope of Gaume et al. 2019 (Firn addition))md"},
            {"body", R"md(`thickness_noise`)md", R"md(none)md", "",
             R"md(`{ std, correlation_length }`: the thickness varies as t (1 + std f(x, z)), f a smooth Gaussian random field of unit variance with that correlation length (m), from `seed`; clamped at 5 % of t (Gaume et al. 2019 use std 0.25, 10 m))md"},
            {"body", R"md(`slides_on`)md", R"md(none)md", "",
             R"md(the name of an earlier body of a `weak_layer` material: this body lies above a **slip surface** on that layer (Firn addition). Its particles get a second grid velocity field: at nodes where both fields have mass they move as one while the layer's mass at the node is mostly intact (bonded: exactly the centre-of-mass velocity one field would give), and as two bodies in Coulomb contact once it has collapsed (full softening, `p0` = 0): no interpenetration along the terrain's normal, slip resisted by `slip_friction` (Bardenhagen et al. 2000). Without it, a slab on a layer a few cells thick stays tied to the snow under the layer by the grid's kernel (three cells wide) after the collapse, a drag that halves with dx ([*Slope-scale runs*](../slope-scale.md)). Give it to the slab and to what rests or lands on it (a trigger); bodies without it (base, weak layer, terrain-side snow) form the lower field; where the two meet without weak-layer mass between them (a ball on the slab when the ball is not above the surface) they touch in frictional contact. One slip surface per scene. The surface's normal is the nearest terrain's)md"},
            {"body", R"md(`slip_friction`)md", R"md(M_d/√3 of the layer)md", "",
             R"md(with `slides_on`: the Coulomb friction of the slip surface once the layer has collapsed (≥ 0; several bodies that give it must agree). The default is the collapsed layer's own critical-state friction in simple shear (q = √3 τ, p = σ_n, so τ/σ_n = M_d/√3: 0.69 for the table's M_d = 1.2, the 0.69 a single weak-layer point sheared to its critical state measures, [*Slope-scale runs*](../slope-scale.md)))md"},
            // [cut]
            {"cut", R"md(`layer`)md", R"md(required)md", "", R"md(name of a layer body)md"},
            {"cut", R"md(`from_x`)md", R"md(required)md", "", R"md(start of the cut along x, m)md"},
            {"cut", R"md(`length`)md", R"md(required)md", "",
             R"md(length along x, m (> 0, shorter than the layer; the cut must overlap the layer))md"},
            {"cut", R"md(`saw`)md", R"md(`"quasi_static"`)md", "",
             R"md(`"quasi_static"`: the cut is made before the snowpack settles, so at t = 0 the slab over it carries its load statically, as behind a field saw (which takes seconds; the overhang responds in milliseconds). `"instant"`: the cut is removed at t = 0 from the settled, uncut column, so the overhang drops and its dynamic overshoot loads the layer beyond the static load (the only saw before 2026-12-02; it fails the PST layer at a cut about a third shorter, [*Snow*](../snow.md)). Without settling (`settle = false`) the two are the same. The quasi-static saw costs settling time, as the overhang bends into place (`scenes/pst3d.toml`: 0.14 s simulated, 1 749 steps, 56 s on 2 cores, against 0.046 s, 568 steps, 18 s), and a cut longer than critical is reported by the settling stage ("N particles carry a static load beyond their strength and yield at t = 0"): the layer at its tip, where the crack starts.)md"},
            // [output]
            {"output", R"md(`directory`)md", R"md(`out/<name>`)md", "",
             R"md(output folder, relative to the working directory)md"},
            {"output", R"md(`particles`)md", R"md(`true`)md", "",
             R"md(write the particle cache per frame)md"},
            {"output", R"md(`volumes`)md", R"md(`["density", "velocity"]`)md", "",
             R"md(volume grids per frame, of `density`, `velocity`, `failed`, `eta` (mass-weighted mean η))md"},
            {"output", R"md(`checkpoint_every_frames`)md", R"md(`0`)md", "",
             R"md(write a checkpoint at the end of every this many frames (0: not by frames; Firn addition))md"},
            {"output", R"md(`checkpoint_every_minutes`)md", R"md(`10`)md", "",
             R"md(and whenever this many minutes of wall time have passed since the last one (0: not by time))md"},
            {"output", R"md(`rasters`)md", R"md(`true`)md", "",
             R"md(on a heightfield: write the peak rasters (`rasters/`, see [*Real terrain*](../terrain.md)); `true` without a heightfield is an error)md"},
            {"output", R"md(`raster_cell`)md", R"md(the DEM's)md", "",
             R"md(cell size of the peak rasters, m, over the DEM's extent from its south-west corner)md"},
            {"output", R"md(`path`)md", R"md(derived)md", "",
             R"md(the avalanche's path line (AvaFrame's `path_aimec`): any OGR line file (shapefile, GeoJSON, GeoPackage; its first LineString) in the DEM's coordinates, relative to the scene, in the direction of flow; on a heightfield only. The runout point and `alpha_angle_deg` are measured along it; without it, along the centre of mass's track, extended along its end segments (name fixed by the spec))md"},
            {"output", R"md(`runout_pressure`)md", R"md(`1.0`)md", "",
             R"md(kPa (> 0): the runout point is the far end, along the path, of the cells whose peak pressure reached this (AvaFrame's 1 kPa; name fixed by the spec))md"},
            // [render]
            {"render", R"md(`width`, `height`)md", R"md(`960`, `540`)md", "",
             R"md(image size, pixels, 16–8192)md"},
            {"render", R"md(`color_by`)md", R"md(`"speed"`)md", "",
             R"md(`"density"`, `"speed"`, `"failed"` or `"eta"` (the last two need those grids in `output.volumes`))md"},
            {"render", R"md(`color_range`)md", R"md(automatic)md", "",
             R"md(`[lo, hi]` of the colour map; automatic: 0 to the largest value over the rendered frames (failed: 0 to 1))md"},
            {"render", R"md(`camera_position`, `look_at`)md", R"md(automatic)md", "",
             R"md(m; give both, or neither for the automatic camera (2D: orthographic side view of the x-y plane; 3D: from the side, a little down-slope, 30° up, framing the snow of every rendered frame))md"},
            {"render", R"md(`fov_deg`)md", R"md(`40`)md", "",
             R"md(vertical field of view of the perspective camera, degrees)md"},
            {"render", R"md(`contact_frames`)md", R"md(`12`)md", "",
             R"md(frames on the contact sheet, 1–64)md"},
};

} // namespace

const char* const kKeyTableEnd = "<!-- end of firn keys -->";

const std::vector<SceneKeyDoc>& sceneKeyDocs() {
    static const std::vector<SceneKeyDoc> docs(std::begin(kSceneKeyDocs), std::end(kSceneKeyDocs));
    return docs;
}

std::vector<std::string> sceneKeySections() {
    std::vector<std::string> sections;
    for (const SceneKeyDoc& doc : sceneKeyDocs())
        if (sections.empty() || sections.back() != doc.section) sections.emplace_back(doc.section);
    return sections;
}

std::vector<std::string> keyNames(const SceneKeyDoc& doc) {
    std::vector<std::string> names;
    const std::string keys = doc.keys;
    for (std::size_t open = keys.find('`'); open != std::string::npos;) {
        const std::size_t close = keys.find('`', open + 1);
        if (close == std::string::npos) break;
        names.push_back(keys.substr(open + 1, close - open - 1));
        open = keys.find('`', close + 1);
    }
    return names;
}

std::string sceneKeyTable(const std::string& section) {
    const bool models = section == "material"; // only material keys depend on the model
    std::ostringstream out;
    out << (models ? "| key | default | models | meaning |\n| --- | --- | --- | --- |"
                   : "| key | default | meaning |\n| --- | --- | --- |");
    auto cell = [&out](const char* text) { out << (*text ? " " : "") << text << " |"; };
    for (const SceneKeyDoc& doc : sceneKeyDocs()) {
        if (doc.section != section) continue;
        out << "\n|";
        cell(doc.keys);
        cell(doc.defaultValue);
        if (models) cell(doc.models);
        cell(doc.meaning);
    }
    return out.str();
}

std::string keyTableBegin(const std::string& table) {
    return "<!-- firn keys --markdown: [" + table + "] -->";
}

} // namespace firn
