//! Synthetic frames from `lms-scene`: the project's no-hardware demo.
//!
//! A built-in scene is cast at the 361 bearings of the LMS 180°/0.5° variant
//! from the scene origin, and `count` noisy frames are drawn from one seeded
//! generator (`lms_scene::seeded_rng(seed)`), so the same options always give
//! the same frames. The noise is the LMS mm mode (Gaussian σ, whole mm) with
//! sporadic no-echo dropouts; a beam without a return is
//! [`Invalid::NoEcho`].

use std::path::PathBuf;

use anyhow::{ensure, Result};
use clap::{Args, ValueEnum};
use lms_core::{Frame, Invalid, Variant};
use lms_scene::{seeded_rng, Bearings, ChaCha8Rng, NoiseModel, Pose, Reading, Scene};

use crate::input::InputFrame;

/// The built-in scenes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SceneKind {
    /// A 6 m × 4 m room with a box in front of the sensor.
    Room,
    /// A 2 m wide corridor with a niche.
    Corridor,
    /// A random room (walls, boxes, pillars) drawn from the seed.
    Random,
}

/// Options choosing a synthetic scene and its noise.
#[derive(Args, Clone, Debug, PartialEq)]
pub struct SceneArgs {
    /// Built-in synthetic scene used when no LOG is given
    #[arg(long, value_enum, default_value_t = SceneKind::Room, conflicts_with = "log")]
    pub scene: SceneKind,
    /// Seed of the synthetic noise (and of the random room)
    #[arg(long, default_value_t = 1, conflicts_with = "log")]
    pub seed: u64,
    /// Number of synthetic frames
    #[arg(long, default_value_t = 10, conflicts_with = "log",
          value_parser = crate::options::scene_count)]
    pub count: usize,
    /// Range noise of the synthetic sensor (m)
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.005,
        conflicts_with = "log"
    )]
    pub noise_sigma: f64,
    /// Probability that a synthetic beam reports no echo
    #[arg(long, value_name = "P", default_value_t = 0.01, conflicts_with = "log")]
    pub dropout: f64,
}

impl Default for SceneArgs {
    fn default() -> Self {
        SceneArgs {
            scene: SceneKind::Room,
            seed: 1,
            count: 10,
            noise_sigma: 0.005,
            dropout: 0.01,
        }
    }
}

impl SceneArgs {
    /// An error naming the option that is out of range (`--count`,
    /// `--noise-sigma` in metres, `--dropout` as a probability).
    pub fn check(&self) -> Result<()> {
        ensure!(self.count > 0, "--count must be at least 1");
        ensure!(
            self.noise_sigma.is_finite() && self.noise_sigma >= 0.0,
            "--noise-sigma must be finite and >= 0 (metres)"
        );
        ensure!(
            (0.0..=1.0).contains(&self.dropout),
            "--dropout must be a probability in 0..=1"
        );
        Ok(())
    }

    /// The scene and the seeded generator positioned after drawing it (the
    /// random room draws from it); the noise is drawn next.
    pub fn scene_and_rng(&self) -> (Scene, ChaCha8Rng) {
        let mut rng = seeded_rng(self.seed);
        let scene = match self.scene {
            SceneKind::Room => Scene::room_with_box(),
            SceneKind::Corridor => Scene::corridor(),
            SceneKind::Random => Scene::random_room(&mut rng),
        };
        (scene, rng)
    }

    /// The scene's name as on the command line (`room`, `corridor`,
    /// `random`).
    pub fn scene_name(&self) -> String {
        self.scene
            .to_possible_value()
            .map_or_else(String::new, |v| v.get_name().to_string())
    }
}

/// A frame of the core from simulated readings at the 180°/0.5° bearings.
pub fn frame_from_readings(readings: &[Reading]) -> Result<Frame> {
    let mut frame = Frame::new(Variant::Fov180Res50.geometry(), readings.len())
        .map_err(|e| anyhow::anyhow!("cannot build a frame: {e}"))?;
    for (j, r) in readings.iter().enumerate() {
        match r.metres() {
            Some(d) => frame.set_metres(j, d as f32),
            None => frame.set_invalid(j, Invalid::NoEcho),
        }
    }
    Ok(frame)
}

/// The frames of a synthetic scene, indexed from 0.
pub fn frames(args: &SceneArgs) -> Result<Vec<InputFrame>> {
    frames_iter(args)?.collect()
}

/// The frames of [`frames`], one at a time (memory independent of
/// `--count`).
pub fn frames_iter(args: &SceneArgs) -> Result<impl Iterator<Item = Result<InputFrame>>> {
    args.check()?;
    let (scene, mut rng) = args.scene_and_rng();
    let bearings = Bearings::lms_180_half_deg();
    debug_assert_eq!(bearings.n, Variant::Fov180Res50.beams());
    let truth = scene.cast(&bearings, Pose::IDENTITY);
    let noise = NoiseModel::gaussian(args.noise_sigma)
        .with_quantisation(lms_core::Unit::Millimetre)
        .with_dropout(args.dropout);
    Ok((0..args.count).map(move |index| {
        let readings = truth.noisy(&noise, &mut rng);
        Ok(InputFrame {
            index,
            frame: frame_from_readings(&readings)?,
            pose: None,
        })
    }))
}

/// What a simulated sensor plays (`simulate`, `verify`): the synthetic
/// scene, or the scans of a recorded log.
#[derive(Args, Clone, Debug)]
pub struct PlayArgs {
    /// The synthetic scene (when no `--replay` log is given).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Play the scans of a CARMEN log (gzip or plain), a capture from
    /// `scan` or a ROS 2 bag instead of the synthetic scene
    #[arg(long = "replay", value_name = "LOG")]
    pub log: Option<PathBuf>,
    /// The topic of a ROS 2 bag replayed.
    #[command(flatten)]
    pub topic: crate::options::TopicArg,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeded_and_deterministic() {
        let args = SceneArgs::default();
        let a = frames(&args).unwrap();
        let b = frames(&args).unwrap();
        assert_eq!(a.len(), 10);
        for (x, y) in a.iter().zip(&b) {
            assert_eq!(x.frame.ranges(), y.frame.ranges());
        }
        assert_ne!(a[0].frame.ranges(), a[1].frame.ranges());
        let other = frames(&SceneArgs {
            seed: 2,
            ..args.clone()
        })
        .unwrap();
        assert_ne!(a[0].frame.ranges(), other[0].frame.ranges());
        for kind in [SceneKind::Corridor, SceneKind::Random] {
            let f = frames(&SceneArgs {
                scene: kind,
                count: 1,
                ..args.clone()
            })
            .unwrap();
            assert_eq!(f[0].frame.len(), 361);
        }
        assert!(frames(&SceneArgs { count: 0, ..args }).is_err());
    }
}
