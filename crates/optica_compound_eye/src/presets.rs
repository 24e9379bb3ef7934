//! Compound eyes of real insects: ommatidia counts, facet sizes and
//! interommatidial angles, each with its source.

use optica_optics::compound_eye::ball_focal_length;

use crate::{CompoundEye, EyeLattice};

/// `√3/2`: the area of a hexagonal cell of unit pitch.
const HEX_CELL_AREA: f64 = 0.866_025_403_784_438_6;

/// A species' compound eye, with the source of its numbers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyePreset {
    /// Common and Latin name.
    pub name: &'static str,
    /// Ommatidia (facets) per eye, about.
    pub ommatidia: u32,
    /// Facet (lens) diameter in micrometres, about: place the eye at the
    /// scale where one facet of the mesh has this size.
    pub facet_diameter_um: f32,
    /// Angle between neighbouring ommatidial axes in degrees, about (the
    /// finest the eye resolves).
    pub interommatidial_deg: f32,
    /// Where the numbers come from.
    pub source: &'static str,
}

/// The fruit fly *Drosophila melanogaster*.
pub const DROSOPHILA: EyePreset = EyePreset {
    name: "fruit fly (Drosophila melanogaster)",
    ommatidia: 780,
    facet_diameter_um: 16.0,
    interommatidial_deg: 4.8,
    source: "ommatidia: D. F. Ready, T. E. Hanson, S. Benzer, \"Development of the Drosophila retina, a \
             neurocrystalline lattice\", Developmental Biology 53 (1976) 217–240 (about 800); facet and \
             angle: M. F. Land, \"Visual acuity in insects\", Annual Review of Entomology 42 (1997) 147–177",
};

/// The honeybee worker, *Apis mellifera*.
pub const HONEYBEE: EyePreset = EyePreset {
    name: "honeybee worker (Apis mellifera)",
    ommatidia: 5_400,
    facet_diameter_um: 20.0,
    interommatidial_deg: 1.9,
    source: "M. F. Land, \"Visual acuity in insects\", Annual Review of Entomology 42 (1997) 147–177; \
             ommatidia counts of about 5,000–5,500 per worker eye are typical of the literature",
};

/// The housefly, *Musca domestica*.
pub const HOUSEFLY: EyePreset = EyePreset {
    name: "housefly (Musca domestica)",
    ommatidia: 3_000,
    facet_diameter_um: 25.0,
    interommatidial_deg: 2.5,
    source: "M. F. Land, \"Visual acuity in insects\", Annual Review of Entomology 42 (1997) 147–177; \
             about 3,000 ommatidia per eye (M. F. Land and D.-E. Nilsson, Animal Eyes, 2nd ed., \
             Oxford University Press 2012, ch. 7)",
};

/// A large dragonfly, the green darner *Anax junius*.
pub const DRAGONFLY: EyePreset = EyePreset {
    name: "dragonfly (Anax junius)",
    ommatidia: 28_000,
    facet_diameter_um: 50.0,
    interommatidial_deg: 0.24,
    source: "T. E. Sherk, \"Development of the compound eyes of dragonflies (Odonata). III. Adult \
             compound eyes\", Journal of Experimental Zoology 203 (1978) 61–80 (the angle is the acute \
             zone's)",
};

/// Every preset, for a settings panel.
pub const PRESETS: [EyePreset; 4] = [DROSOPHILA, HONEYBEE, HOUSEFLY, DRAGONFLY];

impl EyePreset {
    /// Facets per UV unit for a mesh whose UV square `[0, 1]²` covers one
    /// eye once: the hexagonal lattice puts `R_t² / (√3/2)` lenses in it.
    pub fn facets_per_uv(&self) -> f32 {
        (self.ommatidia as f64 * HEX_CELL_AREA).sqrt() as f32
    }
}

impl CompoundEye {
    /// A compound eye with `preset`'s number of facets over the mesh's UV
    /// square: hexagonal touching lenses (real facets are packed edge to
    /// edge), index 1.5 (a typical insect cornea), the pigment plane at the
    /// lenses' paraxial focus (where real rhabdoms start), the other settings
    /// at their defaults.
    pub fn from_preset(preset: &EyePreset) -> Self {
        let index = 1.5;
        Self {
            facets_per_uv: preset.facets_per_uv(),
            lattice: EyeLattice::Hexagonal,
            lens_radius: 1.0,
            lens_index: index as f32,
            // Depth in lens radii: the centre is one radius deep, the focus
            // n/(2(n−1)) radii beyond it.
            pigment_depth: (1.0 + ball_focal_length(1.0, index)) as f32,
            ..Default::default()
        }
    }
}
