//! # lms-scene — synthetic LMS 2xx scans with ground truth
//!
//! Seeded, deterministic scenes for tests, the simulated sensor and the
//! evaluation tool. Plain `std` and `f64`; of `lms-core` it uses only the
//! range unit type ([`Unit`]), so it can serve as the ground truth the core
//! is checked against.
//!
//! The data flow:
//!
//! 1. [`geometry`] — points, the sensor [`Pose`], polar lines
//!    `x·cos α + y·sin α = r` (metres, radians).
//! 2. [`scene`] — a [`Scene`] of straight [`Wall`]s and circular [`Arc`]s,
//!    each with a [`SurfaceId`]; ray casting. The built-in scenes are
//!    [`Scene::room_with_box`], [`Scene::corridor`], [`Scene::random_room`],
//!    [`Scene::single_wall`], [`Scene::arc`] and [`Scene::two_walls_corner`].
//! 3. [`bearings`] — the beam bearings of the five LMS variants
//!    ([`Bearings`], ALGORITHM.md §1: x forward, y left, beam 0 on the right).
//! 4. [`truth`] — [`Scene::cast`] gives a [`TrueScan`]: per beam the true
//!    range, surface and hit point; the true lines and corners; what every
//!    three-beam window lies on ([`TrueScan::true_edge_points`]); the jumps.
//! 5. [`noise`] — a [`NoiseModel`] (Gaussian σ, dropouts, mm/cm
//!    quantisation) turns a [`TrueScan`] into [`Reading`]s, which convert to
//!    LMS raw values (error code 8191 for no echo) or `f32` metres.
//! 6. [`lms`] — [`LmsModel`], a sensor that looks like a real LMS: the
//!    interleaved mirror turns with platform motion, beam footprint and
//!    mixed pixels, incidence-dependent noise, quantisation (mm, cm, 5 cm),
//!    each mode's error codes and the fill values logs use, dropouts.
//!
//! ```
//! use lms_scene::{Bearings, NoiseModel, Pose, Scene, seeded_rng};
//!
//! let truth = Scene::room_with_box().cast(&Bearings::default(), Pose::IDENTITY);
//! assert_eq!(truth.returns(), 361);
//! let readings = truth.noisy(&NoiseModel::lms_mm(), &mut seeded_rng(42));
//! let raw = lms_scene::to_raw(&readings, lms_scene::Unit::Millimetre);
//! assert!(raw.iter().all(|&v| v < 8183));
//! println!("{} lines, edge points {:?}", truth.lines.len(), truth.true_edge_points());
//! ```
#![forbid(unsafe_code)]
#![deny(missing_docs)]

pub mod bearings;
mod builtin;
pub mod geometry;
pub mod lms;
pub mod noise;
pub mod scene;
pub mod truth;

#[cfg(test)]
mod tests;

pub use bearings::Bearings;
pub use geometry::{wrap_angle, Point, PolarLine, Pose};
pub use lms::{LmsModel, LogMode, LogValue, NoEcho};
pub use noise::{
    quantise, to_f32_metres, to_raw, NoiseModel, Reading, Unit, NO_RETURN_F32, RAW_ABOVE_MAX,
    RAW_NO_ECHO,
};
pub use rand_chacha::ChaCha8Rng;
pub use scene::{
    Arc, RayHit, Scene, Surface, SurfaceId, Wall, DEFAULT_MAX_RANGE, LMS_MM_MAX_RANGE,
};
pub use truth::{Hit, TrueCorner, TrueLine, TrueScan, WindowTruth};

/// The generator the crate's scenes and noise are meant to be drawn with:
/// `ChaCha8Rng::seed_from_u64(seed)`.
pub fn seeded_rng(seed: u64) -> ChaCha8Rng {
    use rand::SeedableRng;
    ChaCha8Rng::seed_from_u64(seed)
}
