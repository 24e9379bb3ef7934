#define_import_path optica_lens_flare::types

// The records the flare's passes share (`FlareParams`, `GridJob`,
// `RayOut`, `LightProbe`), imported by each; the Rust side
// is `draws.rs` (`FlareParams`, `GridJob`, `LightProbe`) and the ray
// buffer's 48 bytes.

struct FlareParams {
    rays: u32,
    jobs: u32,
    surfaces: u32,
    sensor_z: f32,
    half_height_mm: f32,
    aspect: f32,
    max_gain: f32,
    intensity: f32,
    blades: u32,
    rotation: f32,
    radius: f32,
    arc_w: f32,
    // Occlusion (`visibility.wgsl`).
    lights: u32,
    occlusion_radius_px: f32,
    occlusion_history: f32,
    reset_history: u32,
    // The starburst (`ghost_draw.wgsl`) and ringing.
    starburst_half_ndc: f32,
    starburst_scale: f32,
    ringing: u32,
    threads: u32,
    // TAA (`visibility.wgsl`).
    jitter_ndc: vec2<f32>,
    jitter_cycle: u32,
    jitter_slot: u32,
    // The cell pass (`ghost_cells.wgsl`).
    cells: u32,
    spans: u32,
}

// One grid: the ray at pupil (u, v) starts at origin + u·du + v·dv and
// travels along dir; `lens_base` is where its wavelength's lens starts in
// `lens`; color.w is the wavelength, nm; `light` indexes the lights'
// visibility; `n` rays per side, from `ray_base` in the ray buffer; its
// first `rows` rows traced from `thread_base` among the trace's threads
// (the rest, with symmetry, their mirror images), and turned by
// `rotation` (cos, sin of the light's azimuth); its cells from `cell_base`
// among all grids' cells, their row spans from `span_base` among the cell
// pass's threads.
struct GridJob {
    origin: vec3<f32>,
    first: u32,
    du: vec3<f32>,
    second: u32,
    dv: vec3<f32>,
    lens_base: u32,
    dir: vec3<f32>,
    cell_pupil_area: f32,
    color: vec4<f32>,
    light: u32,
    n: u32,
    ray_base: u32,
    thread_base: u32,
    rotation: vec2<f32>,
    rows: u32,
    cell_base: u32,
    span_base: u32,
    // The cell pass draws a 2 × 2 block of its cells as one where their
    // irradiances are within this share of each other (0: never).
    merge: f32,
}

// Where a light's depth is read: its image (NDC) and the largest scene
// depth that does not hide it; read_depth 0 for a light with no image.
struct LightProbe {
    ndc: vec2<f32>,
    depth_limit: f32,
    read_depth: u32,
    color: vec4<f32>,
}

struct RayOut {
    sensor: vec2<f32>,
    r_rel: f32,
    throughput: f32,
    stop_first: vec2<f32>,
    stop_second: vec2<f32>,
    stop_third: vec2<f32>,
    alive: f32,
    // Its grid's light (`GridJob::light`), for the draw's visibility.
    light: f32,
}
