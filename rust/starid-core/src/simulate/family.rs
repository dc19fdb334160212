//! The hostile-field scene families (Kelvins-style K1, narrow K2, deep K3): camera, what it
//! sees and the catalogue each is identified against.

use super::{simulate, FalseStarMags, SimConfig, SimFrame};
use crate::catalog::Catalog;
use crate::error::{Error, Result};
use crate::geometry::Camera;

/// Scene families in the style of ESA's Kelvins "Star Trackers: First Contact" competition and
/// of OpenStarTracker's scene simulator: the camera, what it sees and the catalogue depth each
/// is meant to be identified against. Scenes of odd seed are mirrored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Family {
    /// Kelvins: 1920×1440 px, 10°×7.5° (18.75″/px), stars to magnitude 6.2 after photometric
    /// noise, 0–80 false spots (mean 40) with catalogue-like magnitudes, 0.2 px centroid noise.
    K1,
    /// Narrow: 1392×1080 px, 6°×4.66°, stars to 7.75, 0–10 false spots (a catalogue to 8).
    K2,
    /// Deep: 1392×1040 px at 15.78″/px (6.1°×4.56°), stars to 11 against a catalogue to 11,
    /// 0–2 false spots, plus stars the catalogue lacks (0.3 per catalogued star, 8 to 11 mag).
    K3,
}

impl Family {
    /// Every family.
    pub const ALL: [Family; 3] = [Family::K1, Family::K2, Family::K3];

    /// Short name: `K1`, `K2`, `K3`.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Family::K2.name(), "K2");
    /// ```
    pub fn name(self) -> &'static str {
        match self {
            Self::K1 => "K1",
            Self::K2 => "K2",
            Self::K3 => "K3",
        }
    }

    /// The family named `name` (case-insensitive).
    ///
    /// # Errors
    /// `InvalidInput` for an unknown name.
    ///
    /// # Example
    /// ```
    /// assert_eq!(starid_core::Family::from_name("k1").unwrap(), starid_core::Family::K1);
    /// ```
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|f| f.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| {
                Error::invalid_input(format!("unknown scene family {name:?} (K1, K2 or K3)"))
            })
    }

    /// The family's camera.
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.camera().fov_rad() > 0.0);
    /// ```
    pub fn camera(self) -> Camera {
        let c = match self {
            Self::K1 => Camera::from_fov(10f64.to_radians(), 1920.0, 1440.0),
            Self::K2 => Camera::from_fov(6f64.to_radians(), 1392.0, 1080.0),
            Self::K3 => Camera::from_focal_length(206_264.806 / 15.78, 1392.0, 1040.0),
        };
        c.expect("family cameras are valid")
    }

    /// Faintest catalogue magnitude the family is meant to be identified against (Hp or V).
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.catalog_mag_limit() > 5.0);
    /// ```
    pub fn catalog_mag_limit(self) -> f64 {
        match self {
            Self::K1 => 6.5,
            Self::K2 => 8.0,
            Self::K3 => 11.0,
        }
    }

    /// What scene `seed` of the family simulates (odd seeds mirrored).
    ///
    /// # Example
    /// ```
    /// assert!(starid_core::Family::K1.sim_config(3).false_stars_max.is_some());
    /// ```
    pub fn sim_config(self, seed: u64) -> SimConfig {
        let base = SimConfig {
            noise_px: 0.2,
            mag_noise: 0.02,
            photon_sigma_at_limit: 0.1,
            false_star_mags: FalseStarMags::FromCatalog,
            mirrored: seed % 2 == 1,
            ..Default::default()
        };
        match self {
            Self::K1 => SimConfig {
                mag_limit: Some(6.2),
                false_stars: 0,
                false_stars_max: Some(80),
                ..base
            },
            Self::K2 => SimConfig {
                mag_limit: Some(7.75),
                false_stars: 0,
                false_stars_max: Some(10),
                ..base
            },
            Self::K3 => SimConfig {
                mag_limit: Some(11.0),
                false_stars: 0,
                false_stars_max: Some(2),
                uncatalogued_per_real: 0.3,
                uncatalogued_mag_min: 8.0,
                ..base
            },
        }
    }

    /// Scene `seed` of the family over `catalog` (which should reach
    /// [`Family::catalog_mag_limit`]).
    ///
    /// # Errors
    /// As [`simulate`].
    ///
    /// # Example
    /// ```
    /// let cat = starid_core::simulate::random_catalog(20_000, 1.0, 7.5, 1).unwrap();
    /// let frame = starid_core::Family::K2.simulate(&cat, 5).unwrap();
    /// assert!(!frame.centroids.is_empty());
    /// ```
    pub fn simulate(self, catalog: &Catalog, seed: u64) -> Result<SimFrame> {
        simulate(catalog, &self.camera(), &self.sim_config(seed), seed)
    }
}
