// The voxel field's lookup, the twin of
// `DisplacementField::displacement_along_sight` and `expand`: the set of
// the voxel that holds `p` (the paper's lookup, one transform), or, for a
// point beyond the box, the set where its sight line from `start` leaves
// the box, scaled by distance; clone k of S moves by x·m_x + y·m_y for
// pupil sample (x, y). Needs `field: array<f32>` (the voxel's map m_x,
// m_y: 6 floats per voxel, x-fastest voxels) and `displacement.wgsl`
// beside it.

fn field_displacement(p: vec3<f32>, start: vec3<f32>, k: u32, c: CloneParams) -> vec3<f32> {
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
    let v = u32(cell.x) + c.grid_dims.x * (u32(cell.y) + c.grid_dims.y * u32(cell.z));
    let i = 6u * v;
    let mx = vec3<f32>(field[i], field[i + 1u], field[i + 2u]);
    let my = vec3<f32>(field[i + 3u], field[i + 4u], field[i + 5u]);
    let pupil = pupil_sample(k, c.clones);
    return (mx * pupil.x + my * pupil.y) * scale;
}
