// The iris: whether a point of the stop plane is inside the opening, the
// WGSL twin of `optica_optics::lens_flare::Aperture::contains`. `blades` 0
// is a round iris of `radius`; otherwise a regular polygon with one vertex
// at `rotation` whose edges are arcs with `arc_w` = 1/q (see the twin's
// docs): `½ w |p|² + (1 − w r cos h)(p·n) <= r cos h − ½ w r² cos 2h` for
// every edge normal n, h = π/blades.
fn aperture_contains(p: vec2<f32>, blades: u32, rotation: f32, radius: f32, arc_w: f32) -> bool {
    if radius <= 0.0 {
        return false;
    }
    if blades == 0u {
        return dot(p, p) <= radius * radius;
    }
    let half = 3.14159265358979 / f32(blades);
    let inradius = radius * cos(half);
    let quadratic = 0.5 * arc_w * dot(p, p);
    let bound = inradius - 0.5 * arc_w * radius * radius * cos(2.0 * half);
    let linear = 1.0 - arc_w * inradius;
    for (var k = 0u; k < blades; k++) {
        let a = rotation + f32(2u * k + 1u) * half;
        if quadratic + linear * (p.x * cos(a) + p.y * sin(a)) > bound {
            return false;
        }
    }
    return true;
}
