//! The prefilter's tables: for each material, the facet average per view
//! direction ([`PrefilterTable`]) built on the CPU whenever its optics
//! change, uploaded as a small float texture the shader reads.

use std::collections::HashMap;

use bevy::asset::{AssetEvent, RenderAssetUsages};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use optica_optics::compound_eye::{
    DarkCentre, MAX_EXACT_LENSES, PrefilterTable, ShadeOptions, TABLE_AZIMUTHS, TABLE_POLARS,
};

use crate::{CompoundEye, CompoundEyeMaterial, Error};

/// The tables made so far, by the settings they were made from: materials
/// with the same optics share one. Only the materials hold them, so a table
/// no material uses any more (a slider dragged past its setting) is freed.
#[derive(Resource, Default)]
pub(crate) struct PrefilterTables {
    by_key: HashMap<TableKey, AssetId<Image>>,
    /// The materials whose table could not be built, and why.
    pub(crate) failed: HashMap<AssetId<CompoundEyeMaterial>, Error>,
}

/// Every setting a table depends on, bit for bit.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
struct TableKey([u32; 9]);

fn key(e: &CompoundEye) -> TableKey {
    TableKey([
        u32::from(e.lattice == crate::EyeLattice::Hexagonal),
        e.lens_radius.to_bits(),
        e.lens_index.to_bits(),
        e.pigment_depth.to_bits(),
        e.pigment.radius.to_bits(),
        e.pigment.softness.to_bits(),
        e.pigment.darkness.to_bits(),
        u32::from(e.fresnel) | u32::from(e.exact) << 1 | u32::from(e.follow_neighbours) << 2,
        if e.exact { 0 } else { e.slices },
    ])
}

/// The shading path the material's shader follows, for the table.
fn options(e: &CompoundEye) -> ShadeOptions {
    match (e.exact, e.follow_neighbours) {
        (true, true) => ShadeOptions::exact(MAX_EXACT_LENSES),
        (true, false) => ShadeOptions::exact(1),
        (false, true) => ShadeOptions::neighbours(e.slices),
        (false, false) => ShadeOptions::thesis(e.slices),
    }
}

/// The table for `e` as a `TABLE_AZIMUTHS` × `TABLE_POLARS` `Rgba32Float`
/// image, or `None` for settings the shader cannot use.
fn table_image(e: &CompoundEye) -> Result<Image, Error> {
    let pigment = DarkCentre::new(
        e.pigment.radius as f64,
        e.pigment.softness as f64,
        e.pigment.darkness as f64,
    )?;
    let table = PrefilterTable::build(
        e.lattice_kind(),
        e.lens_radius as f64,
        e.lens_index as f64,
        e.pigment_depth as f64,
        &pigment,
        e.fresnel,
        &options(e),
    )?;
    let bytes = table
        .texels()
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    Ok(Image::new(
        Extent3d {
            width: TABLE_AZIMUTHS as u32,
            height: TABLE_POLARS as u32,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        bytes,
        TextureFormat::Rgba32Float,
        RenderAssetUsages::RENDER_WORLD,
    ))
}

/// Gives each added or changed material with the prefilter on the table
/// of its settings, building it the first time those settings are seen
/// (about 74,000 traced rays, spread over the CPU's cores).
pub(crate) fn build_prefilter_tables(
    mut events: MessageReader<AssetEvent<CompoundEyeMaterial>>,
    mut materials: ResMut<Assets<CompoundEyeMaterial>>,
    mut images: ResMut<Assets<Image>>,
    mut tables: ResMut<PrefilterTables>,
) {
    let changed: Vec<_> = events
        .read()
        .filter_map(|event| match event {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for id in changed {
        let Some(material) = materials.get(id) else {
            continue;
        };
        let eye = &material.extension;
        tables.failed.remove(&id);
        if !eye.prefilter || eye.validate().is_err() {
            continue;
        }
        let k = key(eye);
        let kept = tables
            .by_key
            .get(&k)
            .and_then(|&id| images.get_strong_handle(id));
        let handle = match kept {
            Some(handle) => handle,
            None => {
                let image = match table_image(eye) {
                    Ok(image) => image,
                    Err(why) => {
                        warn!("compound eye material {id}: {why}");
                        tables.failed.insert(id, why);
                        continue;
                    }
                };
                let handle = images.add(image);
                tables.by_key.insert(k, handle.id());
                handle
            }
        };
        // Only a new table touches the material (which sends another
        // `Modified`, then finds its table in place).
        if eye.prefilter_table.as_ref() != Some(&handle)
            && let Some(mut material) = materials.get_mut(id)
        {
            material.extension.prefilter_table = Some(handle);
        }
    }
}
