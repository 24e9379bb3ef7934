//! Building twin meshes and line meshes (CPU only, in this binary because
//! the plugin crates' own test targets are off: Bevy links once): an
//! indexed, coloured line strip refined onto its segments, meshes no twin
//! can be made of, and the line-mesh builders.

use bevy::asset::RenderAssetUsages;
use bevy::math::Affine3A;
use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use optica_dome::lines::{Graticule, polyline, segments};
use optica_dome::{pre_subdivide_mesh_asset, refine_mesh_asset};
use optica_optics::dome::{DomeProjection, DomeSettings, SplitRule};

/// A mesh's positions.
fn positions(mesh: &Mesh) -> Vec<Vec3> {
    match mesh.attribute(Mesh::ATTRIBUTE_POSITION) {
        Some(VertexAttributeValues::Float32x3(p)) => {
            p.iter().map(|&a| Vec3::from_array(a)).collect()
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn graticule_lies_on_its_sphere_with_the_asked_lines() {
    let g = Graticule {
        radius: 10.0,
        altitude_step_deg: 30.0,
        azimuth_step_deg: 45.0,
        max_chord_deg: 5.0,
    };
    let mesh = g.mesh();
    assert_eq!(mesh.primitive_topology(), PrimitiveTopology::LineList);
    let p = positions(&mesh);
    assert!(p.iter().all(|v| (v.length() - 10.0).abs() < 1e-4));
    // 8 meridians of 4 segments; circles at −60, −30, 0, 30, 60 of 72
    // chords each.
    assert_eq!(mesh.indices().unwrap().len(), 2 * (8 * 4 + 5 * 72));
    // A bad step falls back, still a valid mesh.
    let bad = Graticule {
        altitude_step_deg: f32::NAN,
        ..g
    }
    .mesh();
    assert!(positions(&bad).iter().all(|v| v.is_finite()));
    assert_eq!(bad.indices().unwrap().len(), 2 * (8 * 4 + 72));
    // A tiny step is held at 0.1°: 3600 meridians, not 3.6e9.
    let fine = Graticule {
        azimuth_step_deg: 1e-9,
        ..g
    }
    .mesh();
    assert_eq!(fine.indices().unwrap().len(), 2 * (3600 * 4 + 5 * 72));
}

#[test]
fn polylines_close_when_asked() {
    let pts = [Vec3::X, Vec3::Y, Vec3::Z];
    assert_eq!(polyline(&pts, false).indices().unwrap().len(), 4);
    assert_eq!(polyline(&pts, true).indices().unwrap().len(), 6);
    assert_eq!(segments(&[[Vec3::X, Vec3::Y]]).count_vertices(), 2);
}

fn dome() -> DomeProjection {
    DomeProjection::new(&DomeSettings {
        fov_deg: 180.0,
        tilt_deg: 0.0,
        size_px: 1024,
        ..Default::default()
    })
    .unwrap()
}

/// An indexed strip 0 → 2 → 1 → 3 of long segments in front of a
/// zenith-looking camera (view −Z), colours red, green, blue, white.
#[test]
fn an_indexed_line_strip_becomes_split_segments_with_mixed_colours() {
    let points = [
        [-5.0f32, 0.0, -1.0],
        [5.0, 0.0, -1.0],
        [0.0, -5.0, -1.0],
        [0.0, 5.0, -1.0],
    ];
    let colours = [
        [1.0f32, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0, 1.0],
        [1.0, 1.0, 1.0, 1.0],
    ];
    let strip = Mesh::new(PrimitiveTopology::LineStrip, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, points.to_vec())
        .with_inserted_attribute(Mesh::ATTRIBUTE_COLOR, colours.to_vec())
        .with_inserted_indices(Indices::U16(vec![0, 2, 1, 3]));
    let rule = SplitRule::chord_gap(0.5).unwrap();
    let out = refine_mesh_asset(&strip, Affine3A::IDENTITY, &dome().into(), rule).unwrap();
    assert_eq!(out.primitive_topology(), PrimitiveTopology::LineList);
    let p = positions(&out);
    let Some(Indices::U32(idx)) = out.indices() else {
        panic!("no indices")
    };
    // Three input segments, each split into several pieces.
    assert!(idx.len() / 2 > 3 * 4, "{} pieces", idx.len() / 2);
    let Some(VertexAttributeValues::Float32x4(c)) = out.attribute(Mesh::ATTRIBUTE_COLOR) else {
        panic!("colours not carried")
    };
    assert_eq!(c.len(), p.len());
    // Every piece lies on one of the strip's segments, and its colour
    // is the mix of that segment's end colours at its place.
    let segments = [[0usize, 2], [2, 1], [1, 3]];
    for &i in idx.iter() {
        let v = p[i as usize];
        let on = segments.iter().find_map(|&[a, b]| {
            let (a3, b3) = (Vec3::from(points[a]), Vec3::from(points[b]));
            let t = (v - a3).dot(b3 - a3) / (b3 - a3).length_squared();
            let off = (a3 + t * (b3 - a3) - v).length();
            (off < 1e-4 && (-1e-4..=1.0 + 1e-4).contains(&t)).then_some((a, b, t))
        });
        let (a, b, t) = on.unwrap_or_else(|| panic!("{v} is on no segment"));
        for k in 0..4 {
            let want = (1.0 - t) * colours[a][k] + t * colours[b][k];
            // Vertices shared by two segments (the strip's corners)
            // carry either segment's end colour: the same.
            assert!(
                (c[i as usize][k] - want).abs() < 1e-3,
                "{v}: {:?}",
                c[i as usize]
            );
        }
    }
}

#[test]
fn unsupported_meshes_give_none() {
    let rule = SplitRule::chord_gap(0.5).unwrap();
    let points = Mesh::new(PrimitiveTopology::PointList, RenderAssetUsages::default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, vec![[0.0f32, 0.0, -1.0]]);
    assert!(refine_mesh_asset(&points, Affine3A::IDENTITY, &dome().into(), rule).is_none());
    let bare = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    );
    assert!(refine_mesh_asset(&bare, Affine3A::IDENTITY, &dome().into(), rule).is_none());
    let tri = Mesh::from(Triangle3d::default());
    assert!(pre_subdivide_mesh_asset(&tri, Affine3A::IDENTITY, f64::NAN).is_none());
    assert!(pre_subdivide_mesh_asset(&tri, Affine3A::IDENTITY, 0.1).is_some());
}

/// The per-frame path of a moving camera: a mesh whose every triangle is
/// small and in front is its own twin ([`Twin::Same`]: nothing built); a
/// mesh with a large triangle gets a twin that starts with the source's
/// own vertices, unchanged, keeps its whole triangles on them, and adds
/// only what refinement made; the same mesh partly behind the view plane
/// is no longer the same.
#[test]
fn small_meshes_in_front_are_their_own_twin() {
    use optica_dome::twins::{Twin, twin_of_mesh};
    let rule = SplitRule::chord_gap(0.5).unwrap();
    let dome = dome().into();
    // A UV sphere of radius 1, 30 above a zenith camera.
    let sphere = Sphere::new(1.0).mesh().uv(16, 8);
    let far = Affine3A::from_translation(Vec3::new(0.0, 0.0, -30.0));
    assert!(matches!(
        twin_of_mesh(&sphere, far, &dome, rule),
        Some(Twin::Same)
    ));
    // Beside the viewer, half behind the view plane: clipped, refined.
    let near = Affine3A::from_translation(Vec3::new(2.0, 0.0, 0.0));
    assert!(matches!(
        twin_of_mesh(&sphere, near, &dome, rule),
        Some(Twin::Refined(_))
    ));
    // Two triangles: one small, one spanning 90° of the sky.
    let mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::default(),
    )
    .with_inserted_attribute(
        Mesh::ATTRIBUTE_POSITION,
        vec![
            [0.0, 0.0, -10.0],
            [0.1, 0.0, -10.0],
            [0.0, 0.1, -10.0],
            [-10.0, 0.0, -1.0],
            [10.0, 0.0, -1.0],
            [0.0, 10.0, -1.0],
        ],
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_UV_0, vec![[0.0f32, 0.0]; 6])
    .with_inserted_indices(Indices::U32(vec![0, 1, 2, 3, 4, 5]));
    let Some(Twin::Refined(twin)) = twin_of_mesh(&mesh, Affine3A::IDENTITY, &dome, rule) else {
        panic!("the large triangle is refined");
    };
    let (src, out) = (positions(&mesh), positions(&twin));
    assert_eq!(
        out[..6],
        src[..],
        "the source's vertices come first, unchanged"
    );
    assert!(out.len() > 6 + 10, "{} vertices", out.len());
    let Some(Indices::U32(i)) = twin.indices() else {
        panic!("u32 indices");
    };
    assert_eq!(i[..3], [0, 1, 2], "the small triangle keeps its vertices");
    // The large one's corners are the source's, not copies.
    for corner in [3, 4, 5] {
        assert!(i[3..].contains(&corner), "corner {corner} is copied");
    }
}
