// The clones' displacement sets (paper §4.2–4.3), the twin of
// `optica_optics::spectacles`: pupil samples (`pupil_samples`), the frame
// across a line of sight (`perpendicular_frame`), the naked eye's closed
// form (`naked_eye_displacements`, `defocus_factor`) and the voxel field's
// lookup (`DisplacementField::displacement_along_sight`).
//
// Everything here is in the eye's frame: +z the line of sight into the
// scene, +y up, +x to the wearer's left, metres, cornea at z = 0.

#define_import_path optica::spectacles

// What a clone needs to know of the eye, the lens and the field (the
// plugin's `CloneUniform`).
struct CloneParams {
    // 0: sharp (no displacement), 1: the naked eye, 2: the voxel field.
    mode: u32,
    // S.
    clones: u32,
    // The atlas: tiles across and down.
    tile_cols: u32,
    tile_rows: u32,
    // Pupil radius A/2 (m).
    pupil_radius: f32,
    // Near and far point vergences (D) of the spherical equivalent.
    p_near: f32,
    p_far: f32,
    // From the centre of rotation to the entrance pupil along the aim (m).
    pupil_offset: f32,
    // z of the centre of rotation (m; it lies on the axis).
    centre_z: f32,
    // z of the camera (the entrance pupil looking straight ahead).
    camera_z: f32,
    // The field's grid: min corner, cell size, cells per axis.
    grid_origin: vec3<f32>,
    grid_cell: vec3<f32>,
    grid_dims: vec3<u32>,
    // 0: shaded in full, 1: reprojected from the sharp view.
    shading: u32,
    // The eye's cylinder (D) and its axis (unit, eye frame x–y).
    cylinder: f32,
    axis: vec2<f32>,
}

// `pupil_samples(count)[k]`: the sunflower spiral, radius √((k + ½)/count),
// angle k·π(3 − √5).
fn pupil_sample(k: u32, count: u32) -> vec2<f32> {
    let golden = 2.399963229728653;
    let r = sqrt((f32(k) + 0.5) / f32(count));
    let a = golden * f32(k);
    return r * vec2<f32>(cos(a), sin(a));
}

// `perpendicular_frame(a)`: e1 = ŷ × a (x̂ × a when a is vertical), e2 = a × e1.
fn perpendicular_frame(a: vec3<f32>) -> mat2x3<f32> {
    var e1 = cross(vec3<f32>(0.0, 1.0, 0.0), a);
    if dot(e1, e1) < 1e-12 {
        e1 = cross(vec3<f32>(1.0, 0.0, 0.0), a);
    }
    e1 = normalize(e1);
    return mat2x3<f32>(e1, cross(a, e1));
}

// `defocus_factor(s, p_near, p_far)`.
fn defocus_factor(s: f32, p_near: f32, p_far: f32) -> f32 {
    if s * p_near < 1.0 {
        return 1.0 - s * p_near;
    }
    if s * p_far > 1.0 {
        return 1.0 - s * p_far;
    }
    return 0.0;
}

// `naked_eye_displacements(eye, placement, p, samples)[k]`: ρ·(e₁ e₂)·K·q,
// K = k(s)·I + s·(the astigmatic part).
fn naked_displacement(p: vec3<f32>, k: u32, c: CloneParams) -> vec3<f32> {
    let centre = vec3<f32>(0.0, 0.0, c.centre_z);
    let to_p = p - centre;
    let len = length(to_p);
    if !(len > 0.0) || len > 3.0e38 {
        return vec3<f32>(0.0);
    }
    let aim = to_p / len;
    let s = length(p - (centre + aim * c.pupil_offset));
    let f = perpendicular_frame(aim);
    let q = pupil_sample(k, c.clones);
    let d = defocus_factor(s, c.p_near, c.p_far);
    var m = mat2x2<f32>(d, 0.0, 0.0, d);
    if c.cylinder != 0.0 {
        // `Eye::astigmatic_matrix`: C·(I/2 − u uᵀ), u the axis across the sight line.
        let axis = vec3<f32>(c.axis, 0.0);
        var u = vec2<f32>(dot(axis, f[0]), dot(axis, f[1]));
        let len = length(u);
        u = select(vec2<f32>(1.0, 0.0), u / len, len > 0.0);
        let astig = c.cylinder * (mat2x2<f32>(0.5, 0.0, 0.0, 0.5) - mat2x2<f32>(u * u.x, u * u.y));
        m = m + astig * s;
    }
    let w = m * q;
    return (f[0] * w.x + f[1] * w.y) * c.pupil_radius;
}

// Where the sight line from the pupil centre `start` to `p` leaves the
// field's box (`DisplacementField::displacement_along_sight`): the ray
// parameter in [0, 1] of the last point inside, or −1 when the segment
// never enters the box.
fn box_exit(start: vec3<f32>, p: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> f32 {
    let d = p - start;
    var t0 = 0.0;
    var t1 = 1.0;
    for (var a = 0u; a < 3u; a++) {
        if d[a] == 0.0 {
            if start[a] < lo[a] || start[a] > hi[a] {
                return -1.0;
            }
        } else {
            let ta = (lo[a] - start[a]) / d[a];
            let tb = (hi[a] - start[a]) / d[a];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    if t1 < t0 {
        return -1.0;
    }
    return t1;
}
