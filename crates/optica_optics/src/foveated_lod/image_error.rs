//! Image error of a foveated render against the full-quality render.
//!
//! * [`rmse`]: root-mean-square difference over all pixels and the three
//!   linear-RGB channels.
//! * [`weighted_rmse`] (the report's `gaze_weighted_rmse` column): the same
//!   with each pixel weighted by a non-negative weight, normally the pixel's
//!   continuous eq. 8 level: an error where the viewer looks counts fully,
//!   one outside the field not at all. This is the error the method promises
//!   to keep small; plain RMSE also counts the periphery it deliberately
//!   degrades.

use glam::DVec3;

use super::error::FoveatedError;

/// RMS difference over all pixels and channels.
pub fn rmse(a: &[DVec3], b: &[DVec3]) -> Result<f64, FoveatedError> {
    weighted_rmse(a, b, &vec![1.0; a.len()])
}

/// Weighted RMS difference: √(Σ wᵢ |aᵢ − bᵢ|² / (3 Σ wᵢ)). All weights zero
/// gives 0 (no pixel the viewer can see). Errors: length mismatch, a
/// negative or non-finite weight, or a non-finite pixel.
pub fn weighted_rmse(a: &[DVec3], b: &[DVec3], w: &[f64]) -> Result<f64, FoveatedError> {
    if a.len() != b.len() || a.len() != w.len() {
        return Err(FoveatedError::InvalidParameter(format!(
            "image sizes differ: {}, {}, {} weights",
            a.len(),
            b.len(),
            w.len()
        )));
    }
    if w.iter().any(|&x| !(x >= 0.0 && x.is_finite())) {
        return Err(FoveatedError::InvalidParameter("weights must be finite and ≥ 0".into()));
    }
    if a.iter().chain(b).any(|p| !p.is_finite()) {
        return Err(FoveatedError::NonFinite("pixel"));
    }
    let sw: f64 = w.iter().sum();
    if sw == 0.0 {
        return Ok(0.0);
    }
    let se: f64 = a
        .iter()
        .zip(b)
        .zip(w)
        .map(|((p, q), &x)| x * (*p - *q).length_squared())
        .sum();
    Ok((se / (3.0 * sw)).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_errors() {
        // One pixel off by (0.3, 0, 0.4) (|d|² = 0.25) of four: √(0.25/12) = 0.1443.
        let a = vec![DVec3::ZERO; 4];
        let mut b = a.clone();
        b[2] = DVec3::new(0.3, 0.0, 0.4);
        assert!((rmse(&a, &b).unwrap() - (0.25f64 / 12.0).sqrt()).abs() < 1e-15);
        // Weight only that pixel: √(0.25/3).
        let w = [0.0, 0.0, 1.0, 0.0];
        assert!((weighted_rmse(&a, &b, &w).unwrap() - (0.25f64 / 3.0).sqrt()).abs() < 1e-15);
        // Weight only the others: 0.
        assert_eq!(weighted_rmse(&a, &b, &[1.0, 1.0, 0.0, 1.0]).unwrap(), 0.0);
        assert_eq!(weighted_rmse(&a, &b, &[0.0; 4]).unwrap(), 0.0);
        assert!(weighted_rmse(&a, &b, &[f64::NAN, 0.0, 0.0, 0.0]).is_err());
        assert!(rmse(&a, &b[1..]).is_err());
        b[0] = DVec3::NAN;
        assert!(rmse(&a, &b).is_err());
    }
}
