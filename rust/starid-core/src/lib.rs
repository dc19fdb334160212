//! # starid-core
//!
//! Lost-in-space star identification in plain Rust (no Python): tell a star tracker which
//! catalogue stars its centroids are, and where it points.
//!
//! ## Pipeline
//! catalogue ([`Catalog`]) → pair index ([`PairIndex`], Mortari's k-vector) → identification
//! ([`Solver::identify`], Pyramid with a fourth-star confirmation and full verification) →
//! attitude from all matched stars ([`attitude::wahba_svd`]) → [`Identification`], with a bound
//! on the probability that the solution is a false match and the time it took.
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
//! use starid_core::{simulate, Camera, Catalog, IdentifyConfig, SimConfig, Solver};
//!
//! // A toy catalogue: a 1° grid of stars over a patch of sky.
//! let (mut ids, mut ra, mut dec, mut mag) = (vec![], vec![], vec![], vec![]);
//! for i in 0..30 {
//!     for j in 0..30 {
//!         ids.push((i * 30 + j) as i64);
//!         ra.push(i as f64 * 1.0 + 0.13 * j as f64);
//!         dec.push(j as f64 * 1.0 - 15.0 + 0.07 * (i * i % 7) as f64);
//!         mag.push(5.0);
//!     }
//! }
//! let catalog = Arc::new(Catalog::new(ids, &ra, &dec, mag).unwrap());
//! let camera = Camera::from_fov(8f64.to_radians(), 512.0, 512.0).unwrap();
//! let solver = Solver::for_camera(catalog.clone(), &camera).unwrap();
//! let truth = starid_core::geometry::attitude_from_radec_roll(15f64.to_radians(), 0.0, 0.3);
//! let frame = simulate(&catalog, &camera, &SimConfig { r_icrs_to_cam: Some(truth), ..Default::default() }, 1).unwrap();
//! let id = solver.identify(&frame.centroids, None, &camera, &IdentifyConfig::default()).unwrap();
//! assert!(id.is_identified());
//! assert_eq!(id.catalog_index, frame.catalog_index);
//! ```
//!
//! ## Features
//! - `parallel` (default): rayon builds the pair index and [`Solver::identify_batch`] runs frames in parallel.
#![deny(missing_docs)]

pub mod attitude;
pub mod catalog;
pub mod error;
pub mod geometry;
pub mod identify;
pub mod kvector;
pub mod simulate;
pub mod sky;

pub use catalog::Catalog;
pub use error::{Error, ErrorKind, Result};
pub use geometry::Camera;
pub use identify::{FrameRef, Identification, IdentifyConfig, Solver, Status};
pub use kvector::PairIndex;
pub use simulate::{simulate, SimConfig, SimFrame};
