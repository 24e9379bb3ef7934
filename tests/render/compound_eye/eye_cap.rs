//! The pole-free eye mesh: conformal UVs (square facets everywhere), facet
//! sizes that change smoothly and never shrink to a point, faces outward,
//! and a UV disc of area 1 (a preset's facet count covers it).

use bevy::mesh::{MeshBuilder, VertexAttributeValues};
use bevy::prelude::*;
use optica_compound_eye::EyeCap;
use optica_optics::compound_eye::TextureAxes;
use optica_optics::glam::DVec2;

/// Per triangle: its corners and the texture axes of its UVs.
fn triangles(cap: &EyeCap) -> Vec<([Vec3; 3], TextureAxes)> {
    let mesh = cap.build();
    let Some(VertexAttributeValues::Float32x3(p)) = mesh.attribute(Mesh::ATTRIBUTE_POSITION) else {
        panic!("positions")
    };
    let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute(Mesh::ATTRIBUTE_UV_0) else {
        panic!("uvs")
    };
    let index: Vec<usize> = mesh.indices().expect("indices").iter().collect();
    index
        .chunks_exact(3)
        .map(|t| {
            let corners = [t[0], t[1], t[2]].map(|i| Vec3::from(p[i]));
            let axes = TextureAxes::from_triangle(
                corners.map(|c| c.as_dvec3()),
                [t[0], t[1], t[2]].map(|i| DVec2::from(uv[i].map(f64::from))),
            )
            .expect("a regular triangle");
            (corners, axes)
        })
        .collect()
}

#[test]
fn the_eye_cap_has_square_facets_and_no_pole() {
    let cap = EyeCap::default();
    let tris = triangles(&cap);
    assert_eq!(tris.len(), (96 + 2 * 96 * 31) as usize);
    let (mut smallest, mut largest) = (f64::MAX, 0f64);
    let mut worst_aspect = 0f64;
    let mut worst_angle = 0f64;
    for (corners, axes) in &tris {
        let (u, v) = (axes.u(), axes.v());
        worst_aspect = worst_aspect.max((u.length() / v.length() - 1.0).abs());
        worst_angle = worst_angle.max((u.dot(v) / (u.length() * v.length())).abs());
        smallest = smallest.min(u.length());
        largest = largest.max(u.length());
        // Wound outwards.
        let centre = (corners[0] + corners[1] + corners[2]) / 3.0;
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        assert!(n.dot(centre) > 0.0, "a triangle faces inwards");
    }
    eprintln!(
        "eye cap: |U|/|V| − 1 up to {worst_aspect:.4}, |cos(U, V)| up to {worst_angle:.4}, \
         facet size {smallest:.4}–{largest:.4}"
    );
    // Conformal up to the mesh's piecewise-linear UVs (about 5 % on its
    // 3–4° triangles).
    assert!(worst_aspect < 0.08 && worst_angle < 0.08);
    // Stereographic: the facet shrinks by cos²(θ/2) from the centre to the
    // rim (0.41 at 100°), and nowhere more.
    let expected = f64::from((0.5 * cap.rim_angle()).cos().powi(2));
    let ratio = smallest / largest;
    assert!(
        (ratio / expected - 1.0).abs() < 0.05,
        "{ratio} against {expected}"
    );
    // Tangents for `tangent_axes`: unit, in the surface.
    let mesh = cap.build();
    let Some(bevy::mesh::VertexAttributeValues::Float32x4(tangents)) =
        mesh.attribute(Mesh::ATTRIBUTE_TANGENT)
    else {
        panic!("no tangents")
    };
    let Some(bevy::mesh::VertexAttributeValues::Float32x3(normals)) =
        mesh.attribute(Mesh::ATTRIBUTE_NORMAL)
    else {
        panic!("no normals")
    };
    for (t, n) in tangents.iter().zip(normals) {
        let (t, n) = (Vec3::new(t[0], t[1], t[2]), Vec3::from(*n));
        assert!(
            (t.length() - 1.0).abs() < 1e-3 && t.dot(n).abs() < 1e-3,
            "{t} at {n}"
        );
    }
}

#[test]
fn the_eye_caps_uv_disc_has_area_one_and_bad_settings_are_clamped() {
    let cap = EyeCap::default();
    let rim = cap.rim_angle();
    let r = (cap.uv_at(rim, 0.3) - Vec2::splat(0.5)).length();
    assert!((std::f32::consts::PI * r * r - 1.0).abs() < 1e-5, "{r}");
    assert_eq!(cap.uv_at(0.0, 1.0), Vec2::splat(0.5));
    for half_angle in [f32::NAN, f32::INFINITY, -1.0, 0.0, 4.0] {
        let bad = EyeCap {
            half_angle,
            rings: 0,
            sectors: 1,
        };
        let angle = bad.rim_angle();
        assert!(angle.is_finite() && angle > 0.0 && angle < 3.0, "{angle}");
        let mesh = bad.build();
        let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute(Mesh::ATTRIBUTE_UV_0)
        else {
            panic!("uvs")
        };
        assert!(uv.iter().flatten().all(|x| x.is_finite()));
        assert_eq!(mesh.count_vertices(), 1 + 3);
    }
}
