//! A smooth field of lattice axes on a mesh, for [`CompoundEye::axis_field`]
//! (crate::CompoundEye::axis_field): each vertex's triangles' texture axes
//! averaged (`optica_optics::compound_eye::axis_field`), written into the
//! mesh's tangents and second UV channel, which Bevy's vertex shaders
//! interpolate to the material's fragments.

use bevy::mesh::{Indices, PrimitiveTopology, VertexAttributeValues};
use bevy::prelude::*;
use optica_optics::compound_eye::axis_field;
use optica_optics::glam::{DVec2, DVec3};

use crate::Error;

/// Writes the smooth axis field of `mesh`'s texture coordinates into its
/// `Mesh::ATTRIBUTE_TANGENT` (the axes' direction; existing tangents are
/// replaced) and `Mesh::ATTRIBUTE_UV_1` (their shape: stretch and shear),
/// for a [`CompoundEye`](crate::CompoundEye) with `axis_field` on. After
/// changing the mesh's positions or UVs, remove `Mesh::ATTRIBUTE_UV_1` and
/// call it again. The shape is taken in the mesh's own space: an entity
/// scaled unevenly stretches the facets' directions (the tangents) but not
/// their shape.
///
/// ```
/// use bevy::prelude::*;
/// use optica_compound_eye::insert_axis_field;
///
/// // A coarse UV sphere: its UVs stretch differently on every row, which
/// // each triangle's own axes show as seams.
/// let mut mesh = Sphere::new(1.0).mesh().uv(14, 8);
/// insert_axis_field(&mut mesh).expect("a triangle mesh with UVs");
/// assert!(mesh.attribute(Mesh::ATTRIBUTE_UV_1).is_some());
/// ```
///
/// Errors ([`Error::AxisField`]): a mesh that is not a triangle list, has
/// no positions or no `Float32x2` UVs, or whose second UV channel is
/// already in use (a lightmap's, say), which the field would overwrite.
/// Normals are used where present, else each vertex's triangles' mean.
pub fn insert_axis_field(mesh: &mut Mesh) -> Result<(), Error> {
    if mesh.primitive_topology() != PrimitiveTopology::TriangleList {
        return Err(Error::AxisField("the mesh is not a triangle list"));
    }
    if mesh.attribute(Mesh::ATTRIBUTE_UV_1).is_some() {
        return Err(Error::AxisField(
            "the mesh's second UV channel (Mesh::ATTRIBUTE_UV_1) is in use (remove it to write a new field)",
        ));
    }
    let Some(VertexAttributeValues::Float32x3(positions)) =
        mesh.attribute(Mesh::ATTRIBUTE_POSITION)
    else {
        return Err(Error::AxisField("the mesh has no Float32x3 positions"));
    };
    let Some(VertexAttributeValues::Float32x2(uvs)) = mesh.attribute(Mesh::ATTRIBUTE_UV_0) else {
        return Err(Error::AxisField(
            "the mesh has no Float32x2 texture coordinates",
        ));
    };
    let positions: Vec<DVec3> = positions
        .iter()
        .map(|p| Vec3::from(*p).as_dvec3())
        .collect();
    let uvs: Vec<DVec2> = uvs.iter().map(|t| Vec2::from(*t).as_dvec2()).collect();
    let normals: Vec<DVec3> = match mesh.attribute(Mesh::ATTRIBUTE_NORMAL) {
        Some(VertexAttributeValues::Float32x3(n)) => {
            n.iter().map(|n| Vec3::from(*n).as_dvec3()).collect()
        }
        _ => Vec::new(),
    };
    let indices: Vec<u32> = match mesh.indices() {
        Some(Indices::U16(i)) => i.iter().map(|&k| u32::from(k)).collect(),
        Some(Indices::U32(i)) => i.clone(),
        None => (0..positions.len() as u32).collect(),
    };
    let triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let field = axis_field(&positions, &normals, &uvs, &triangles);
    let tangents: Vec<[f32; 4]> = field
        .iter()
        .map(|f| f.tangent.as_vec4().to_array())
        .collect();
    let shapes: Vec<[f32; 2]> = field.iter().map(|f| f.shape.as_vec2().to_array()).collect();
    mesh.insert_attribute(Mesh::ATTRIBUTE_TANGENT, tangents);
    mesh.insert_attribute(Mesh::ATTRIBUTE_UV_1, shapes);
    Ok(())
}
