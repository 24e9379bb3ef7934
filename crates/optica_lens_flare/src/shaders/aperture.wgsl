#define_import_path optica_lens_flare::aperture

// The iris: whether points of the stop plane are inside the opening, the
// WGSL twin of `optica_optics::lens_flare::Aperture::contains`. `blades` 0
// is a round iris of `radius`; otherwise a regular polygon with one vertex
// at `rotation` whose edges are arcs with `arc_w` = 1/q (see the twin's
// docs): `½ w |p|² + (1 − w r cos h)(p·n) <= r cos h − ½ w r² cos 2h` for
// every edge normal n, h = π/blades.
fn aperture_contains(p: vec2<f32>, blades: u32, rotation: f32, radius: f32, arc_w: f32) -> bool {
    return aperture_contains_all(p, p, p, blades, rotation, radius, arc_w);
}

// Whether all of p0, p1, p2 are inside (a ghost's up to three crossings of
// the stop plane): the edge normals are turned from one to the next
// instead of each taking a sine and cosine, and each serves all three
// points, so that the draw's pixels pay two sines and cosines, not a pair
// per edge and point.
fn aperture_contains_all(p0: vec2<f32>, p1: vec2<f32>, p2: vec2<f32>, blades: u32, rotation: f32, radius: f32, arc_w: f32) -> bool {
    if radius <= 0.0 {
        return false;
    }
    let squared = vec3<f32>(dot(p0, p0), dot(p1, p1), dot(p2, p2));
    if blades == 0u {
        return all(squared <= vec3<f32>(radius * radius));
    }
    let half = 3.14159265358979 / f32(blades);
    let inradius = radius * cos(half);
    let quadratic = 0.5 * arc_w * squared;
    let bound = vec3<f32>(inradius - 0.5 * arc_w * radius * radius * cos(2.0 * half));
    let linear = 1.0 - arc_w * inradius;
    var normal = vec2<f32>(cos(rotation + half), sin(rotation + half));
    let turn = vec2<f32>(cos(2.0 * half), sin(2.0 * half));
    for (var k = 0u; k < blades; k++) {
        let along = vec3<f32>(dot(p0, normal), dot(p1, normal), dot(p2, normal));
        if any(quadratic + linear * along > bound) {
            return false;
        }
        normal = vec2<f32>(turn.x * normal.x - turn.y * normal.y, turn.y * normal.x + turn.x * normal.y);
    }
    return true;
}
