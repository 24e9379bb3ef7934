// The voxel field's lookup, the twin of
// `DisplacementField::displacement_along_sight` and `expand`: the set of
// the voxel that holds `p` (the paper's lookup, one transform), or, for a
// point beyond the box, the set where its sight line from `start` leaves
// the box, scaled by distance; clone k of S moves by x·m_x + y·m_y for
// pupil sample (x, y). Reads the clone material's `field`
// binding (the voxel's map m_x, m_y: 6 floats per voxel, x-fastest
// voxels).

#define_import_path optica::spectacles::field

#import optica::spectacles::{CloneParams, box_exit, pupil_sample}

@group(#{MATERIAL_BIND_GROUP}) @binding(101) var<storage, read> field: array<f32>;

// Clone k's vector of voxel `cell` (x, y, layer indices).
fn field_vector(cell: vec3<f32>, k: u32, c: CloneParams) -> vec3<f32> {
    let v = u32(cell.x) + c.grid_dims.x * (u32(cell.y) + c.grid_dims.y * u32(cell.z));
    let i = 6u * v;
    let mx = vec3<f32>(field[i], field[i + 1u], field[i + 2u]);
    let my = vec3<f32>(field[i + 3u], field[i + 4u], field[i + 5u]);
    let pupil = pupil_sample(k, c.clones);
    return mx * pupil.x + my * pupil.y;
}

// The field in eye coordinates (mode 3), the twin of
// `DisplacementField::map_at` for `FieldLayout::Eye`: the point's
// (x/z', y/z', 1/z') about the centre of rotation; the two layers around
// it in 1/z', each voxel's vector carried to the point's distance, blended
// linearly; at the grid's edges its edge voxels.
fn eye_field_displacement(p: vec3<f32>, k: u32, c: CloneParams) -> vec3<f32> {
    let z = p.z - c.centre_z;
    if !(z > 0.0) {
        return vec3<f32>(0.0);
    }
    let q = vec3<f32>(p.x / z, p.y / z, 1.0 / z);
    let lo = c.grid_origin;
    let size = c.grid_cell;
    let dims = vec3<f32>(c.grid_dims);
    let x = clamp(floor((q.x - lo.x) / size.x), 0.0, dims.x - 1.0);
    let y = clamp(floor((q.y - lo.y) / size.y), 0.0, dims.y - 1.0);
    let layer = clamp((q.z - lo.z) / size.z - 0.5, 0.0, dims.z - 1.0);
    let k0 = min(floor(layer), dims.z - 1.0);
    let k1 = min(k0 + 1.0, dims.z - 1.0);
    let f = layer - k0;
    let a = field_vector(vec3<f32>(x, y, k0), k, c) * (z * (lo.z + (k0 + 0.5) * size.z));
    let b = field_vector(vec3<f32>(x, y, k1), k, c) * (z * (lo.z + (k1 + 0.5) * size.z));
    return a * (1.0 - f) + b * f;
}

fn field_displacement(p: vec3<f32>, start: vec3<f32>, k: u32, c: CloneParams) -> vec3<f32> {
    if c.mode == 3u {
        return eye_field_displacement(p, k, c);
    }
    let lo = c.grid_origin;
    let dims = vec3<f32>(c.grid_dims);
    let hi = lo + c.grid_cell * dims;
    var q = p;
    var scale = 1.0;
    if any(p < lo) || any(p >= hi) {
        let t = box_exit(start, p, lo, hi);
        if !(t > 0.0) {
            return vec3<f32>(0.0);
        }
        q = start + (p - start) * t;
        scale = 1.0 / t;
    }
    let cell = clamp(floor((q - lo) / c.grid_cell), vec3<f32>(0.0), dims - 1.0);
    return field_vector(cell, k, c) * scale;
}
