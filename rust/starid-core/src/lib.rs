//! # starid-core
//!
//! Lost-in-space star identification in plain Rust (no Python): tell a star tracker which
//! catalogue stars its centroids are, and where it points.
//!
//! ## Pipeline
//! catalogue ([`Catalog`]) → pair indexes ([`PairIndex`], Mortari's k-vector, over all stars and
//! over the locally bright ones) → identification ([`Solver::identify`], Pyramid with a
//! fourth-star confirmation and full verification; with magnitudes the brightest stars are tried
//! against the locally bright pairs first, then, with a known zero point, a magnitude-gated
//! Pyramid over every centroid finds a few stars among many false ones; [`Method`] picks
//! geometric voting instead) → attitude from all matched stars
//! ([`attitude::wahba_from`], Gauss–Newton to Wahba's optimum; [`attitude::wahba_svd`] from
//! scratch) → [`Identification`], with a bound on the probability that the solution is a false
//! match and the time it took.
//!
//! ## Frames and units
//! - Pixels: x right, y down, origin at the sensor's top-left corner; the principal point is the
//!   sensor centre `(W/2, H/2)`. A field of view given as one number is the full angle across
//!   the width.
//! - Camera frame: +x right, +y down, +z along the boresight (right-handed).
//! - Attitude: the rotation `r_icrs_to_cam` with `v_cam = r_icrs_to_cam · v_icrs`. A mirrored
//!   frame's attitude is that of the image with its x axis reversed (`x → W − x`).
//! - Angles are radians inside the crate; names carry their unit (`fov_rad`, `focal_length_px`).
//!
//! ## Example
//! ```
//! use std::sync::Arc;
//! use starid_core::simulate::{random_catalog, simulate, SimConfig};
//! use starid_core::{Camera, IdentifyConfig, Solver};
//!
//! // A synthetic sky of 5000 stars, a 12° camera of 512 x 512 px and its pair index.
//! let catalog = Arc::new(random_catalog(5000, 1.0, 6.0, 42).unwrap());
//! let camera = Camera::from_fov(12f64.to_radians(), 512.0, 512.0).unwrap();
//! let solver = Solver::for_camera(catalog.clone(), &camera).unwrap();
//!
//! // A frame from a random attitude with 0.2 px centroid noise, mirrored.
//! let sim = SimConfig { noise_px: 0.2, mirrored: true, ..Default::default() };
//! let frame = simulate(&catalog, &camera, &sim, 7).unwrap();
//!
//! let id = solver.identify(&frame.centroids, None, &camera, &IdentifyConfig::default()).unwrap();
//! assert!(id.is_identified() && id.mirrored);
//! assert_eq!(id.catalog_index, frame.catalog_index);
//! // Boresight within 20″; the roll is less precise (stars sit at most 360 px from the axis).
//! let r = id.r_icrs_to_cam.unwrap();
//! let z = nalgebra::Vector3::z();
//! let boresight_error = r.inverse_transform_vector(&z).angle(&frame.r_icrs_to_cam.inverse_transform_vector(&z));
//! let attitude_error = starid_core::geometry::rotation_angle_between(&r, &frame.r_icrs_to_cam);
//! assert!(boresight_error < 1e-4 && attitude_error < 1e-3);
//! assert!(id.false_match_probability < 1e-6);
//! ```
//!
//! ## Features
//! - `parallel` (default): rayon builds the pair index and [`Solver::identify_batch`] runs frames in parallel.
#![deny(missing_docs)]

pub mod attitude;
pub mod calibrate;
pub mod catalog;
pub mod error;
pub mod extract;
pub mod geometry;
pub mod guide;
pub mod identify;
pub mod image;
pub mod kvector;
pub(crate) mod lsq;
pub mod pointing;
pub mod simulate;
pub(crate) mod sky;
pub mod tracking;
/// The focal-length search (a field of view not known), part of identification.
pub use identify::unknown_focal;

pub use catalog::Catalog;
pub use error::{Error, ErrorKind, Result};
pub use geometry::Camera;
pub use identify::NoiseSource;
pub use identify::{
    AttitudeHint, Cancel, FrameRef, HintFallback, Identification, IdentifyConfig, Method, Solver,
    Status,
};
pub use kvector::PairIndex;
pub use simulate::{simulate, FalseStarMags, Family, SimConfig, SimFrame};
pub use unknown_focal::FocalIdentification;
