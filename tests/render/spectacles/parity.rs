//! The clones' displacement shaders (`displacement.wgsl`,
//! `field_lookup.wgsl`) against their CPU twins by compute readback: the
//! pupil samples (`pupil_samples`), the naked eye's closed form
//! (`naked_eye_displacements`) and the voxel field's lookup
//! (`DisplacementField::displacement_along_sight` and `expand`), at
//! quasi-random points in front of the eye (inside and beyond the field's
//! box) and every clone of S = 10. f32 against f64 (the field's maps are
//! f32 on both sides): every vector within 1e-5 of the set's size (its
//! largest vector) plus 1e-9 m; a voxel lookup may pick the neighbouring
//! voxel only for a point within 1e-5 of a voxel face (none are chosen
//! that close).

use optica_harness::Headless;
use optica_optics::glam::{DVec2, DVec3};
use optica_optics::spectacles::{
    self as optics, DisplacementField, EyePlacement, FieldGrid, FieldSettings, LensDesignParams,
    Prescription, design_lens, naked_eye_displacements, pupil_samples,
};
use optica_report::fixtures::halton;
use optica_spectacles::twins::{DISPLACEMENT_WGSL, FIELD_LOOKUP_WGSL, camera_z, eye_placement};

const CLONES: u32 = 10;

/// The libraries and a kernel: input = the `CloneParams` numbers (19
/// floats), the point count, the points (3 floats each), then the field's
/// maps; per point and clone it writes the naked and the field vectors
/// and the pupil sample (8 floats).
fn kernel() -> String {
    let library: String = DISPLACEMENT_WGSL
        .lines()
        .filter(|l| !l.starts_with("#define_import_path"))
        .collect::<Vec<_>>()
        .join("\n");
    // The lookup reads the material's `field` binding; here the same
    // numbers sit in `input` after the points.
    let lookup: String = FIELD_LOOKUP_WGSL
        .lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("@group"))
        .collect::<Vec<_>>()
        .join("\n")
        .replace("field[", "input[field_at + ");
    format!(
        "{library}
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
var<private> field_at: u32;
{lookup}
fn params() -> CloneParams {{
    var c: CloneParams;
    c.mode = u32(input[20]);
    c.clones = u32(input[0]);
    c.tile_cols = 1u;
    c.tile_rows = 1u;
    c.pupil_radius = input[1];
    c.p_near = input[2];
    c.p_far = input[3];
    c.pupil_offset = input[4];
    c.centre_z = input[5];
    c.camera_z = input[6];
    c.grid_origin = vec3<f32>(input[7], input[8], input[9]);
    c.grid_cell = vec3<f32>(input[10], input[11], input[12]);
    c.grid_dims = vec3<u32>(u32(input[13]), u32(input[14]), u32(input[15]));
    c.cylinder = input[16];
    c.axis = vec2<f32>(input[17], input[18]);
    return c;
}}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let c = params();
    let points = u32(input[19]);
    let i = id.x / c.clones;
    let k = id.x % c.clones;
    if i >= points {{ return; }}
    field_at = 21u + 3u * points;
    let b = 21u + 3u * i;
    let p = vec3<f32>(input[b], input[b + 1u], input[b + 2u]);
    let naked = naked_displacement(p, k, c);
    let field = field_displacement(p, vec3<f32>(0.0, 0.0, c.camera_z), k, c);
    let q = pupil_sample(k, c.clones);
    let w = 8u * id.x;
    output[w] = naked.x;
    output[w + 1u] = naked.y;
    output[w + 2u] = naked.z;
    output[w + 3u] = field.x;
    output[w + 4u] = field.y;
    output[w + 5u] = field.z;
    output[w + 6u] = q.x;
    output[w + 7u] = q.y;
}}"
    )
}


/// Whether `p` lies within `eps` of a face between the field's voxels.
/// In eye coordinates, within `eps` of a face across the sight lines (the
/// lookup blends between layers, so their faces are no edge).
fn near_a_face(field: &DisplacementField, p: DVec3, eps: f64) -> bool {
    let (lo, _) = field.counts().bounds();
    let size = field.counts().cell_size();
    let (q, axes) = match field.layout() {
        optics::FieldLayout::Box => (p, 3),
        optics::FieldLayout::Eye { centre_z } => {
            let z = p.z - centre_z;
            (DVec3::new(p.x / z, p.y / z, 1.0 / z), 2)
        }
    };
    (0..axes).any(|a| {
        let t = (q[a] - lo[a]) / size[a];
        (t - t.round()).abs() * size[a] < eps
    })
}

#[test]
fn naked_eye_and_field_lookup_match_the_cpu_twin() {
    // A −3 D myope presbyope with a 6 mm pupil in +1.5 D reading glasses
    // (n = 1.66), the field at a quarter of the paper's resolution; then
    // the same eye with astigmatism, −1.5 D × 30.
    // Both voxel layouts: the paper's box and eye coordinates.
    let eye = optics::Eye::new(-3.0, 1.5, 0.006).unwrap();
    parity(eye, FieldGrid::Box);
    parity(eye.with_astigmatism(-1.5, 30.0).unwrap(), FieldGrid::Box);
    parity(eye, FieldGrid::Eye);
}

fn parity(eye: optics::Eye, grid: FieldGrid) {
    let placement: EyePlacement = eye_placement();
    let lens = design_lens(
        &Prescription::sphere(1.5).unwrap(),
        &LensDesignParams::paper(),
    )
    .unwrap();
    let field = optics::precompute_field(
        &eye,
        &placement,
        Some(&lens),
        &FieldSettings::paper().scaled(0.25).unwrap().with_grid(grid),
    )
    .unwrap();
    let (lo, _) = field.counts().bounds();
    let from = DVec3::new(0.0, 0.0, f64::from(camera_z()));
    // Points 0.05–8 m ahead within ±40° (beyond the box's far face at 2.13 m
    // and past its sides too), none within 1e-5 m of a voxel face.
    let mut points = Vec::new();
    let mut i = 0;
    while points.len() < 300 {
        i += 1;
        let z = 0.05 * 160f64.powf(halton(i, 2));
        let x = z * 0.84 * (2.0 * halton(i, 3) - 1.0);
        let y = z * 0.84 * (2.0 * halton(i, 5) - 1.0);
        let p = DVec3::new(x, y, z);
        if !near_a_face(&field, p, 1e-5) {
            points.push(p);
        }
    }
    let beyond = points
        .iter()
        .filter(|p| field.counts().cell_of(**p).is_none())
        .count();
    if grid == FieldGrid::Box {
        assert!(beyond > 50 && beyond < 250, "{beyond} of 300 beyond the box");
    }

    let cell = field.counts().cell_size();
    let dims = field.counts().dims();
    let mut input = vec![
        CLONES as f32,
        (0.5 * eye.pupil_diameter_m()) as f32,
        eye.near_point_vergence_d() as f32,
        eye.far_point_vergence_d() as f32,
        placement.pupil_offset_m() as f32,
        placement.centre_of_rotation().z as f32,
        camera_z(),
        lo.x as f32,
        lo.y as f32,
        lo.z as f32,
        cell.x as f32,
        cell.y as f32,
        cell.z as f32,
        dims[0] as f32,
        dims[1] as f32,
        dims[2] as f32,
        eye.cylinder_d() as f32,
        eye.axis_direction().x as f32,
        eye.axis_direction().y as f32,
        points.len() as f32,
        if grid == FieldGrid::Eye { 3.0 } else { 2.0 },
    ];
    for p in &points {
        input.extend(p.to_array().map(|c| c as f32));
    }
    for v in field.maps() {
        input.extend(v.to_array());
    }
    let n = points.len() * CLONES as usize;
    let out = Headless::new(1, 1)
        .run_kernel(&kernel(), "main", &input, 8 * n)
        .expect("kernel");

    let samples: Vec<DVec2> = pupil_samples(CLONES as usize);
    let (mut worst_naked, mut worst_field, mut worst_sample) = (0.0f64, 0.0f64, 0.0f64);
    for (i, p) in points.iter().enumerate() {
        // The GPU's f32 point, so that both sides see the same point.
        let p32 = p.as_vec3().as_dvec3();
        let naked = naked_eye_displacements(&eye, &placement, p32, &samples);
        let naked_size = naked.iter().map(|v| v.length()).fold(0.0, f64::max);
        let set: Vec<DVec3> = match field.displacement_along_sight(p32, from) {
            Some((map, k)) => optics::expand(map, CLONES as usize)
                .iter()
                .map(|v| v.as_dvec3() * k)
                .collect(),
            None => vec![DVec3::ZERO; CLONES as usize],
        };
        let field_size = set.iter().map(|v| v.length()).fold(0.0, f64::max);
        for k in 0..CLONES as usize {
            let w = 8 * (i * CLONES as usize + k);
            let got = |o: usize| DVec3::new(out[w + o] as f64, out[w + o + 1] as f64, out[w + o + 2] as f64);
            let dn = (got(0) - naked[k]).length() / (naked_size + 1e-4);
            let df = (got(3) - set[k]).length() / (field_size + 1e-4);
            assert!(
                (got(0) - naked[k]).length() <= 1e-5 * naked_size + 1e-9,
                "naked, point {p}, clone {k}: {} vs {}",
                got(0),
                naked[k]
            );
            assert!(
                (got(3) - set[k]).length() <= 1e-5 * field_size + 1e-9,
                "field, point {p}, clone {k}: {} vs {}",
                got(3),
                set[k]
            );
            let ds = (DVec2::new(out[w + 6] as f64, out[w + 7] as f64) - samples[k]).length();
            assert!(ds < 1e-6, "pupil sample {k}");
            worst_naked = worst_naked.max(dn);
            worst_field = worst_field.max(df);
            worst_sample = worst_sample.max(ds);
        }
    }
    eprintln!(
        "parity, {grid:?} grid, cylinder {} D, over {} points × {CLONES} clones ({beyond} beyond the box): naked \
         {worst_naked:.2e}, field {worst_field:.2e} of the set's size, pupil samples {worst_sample:.2e}",
        eye.cylinder_d(),
        points.len()
    );
    // The field was not all zeros where the points are (a real check).
    assert!(points.iter().any(|p| field.map_at(*p).is_some_and(|m| m[0].length() > 1e-4)));
}
