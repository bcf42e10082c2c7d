//! [`SceneSource`]: the built-in synthetic scene cast at the bearings of
//! every variant, drawn in the units asked for.

use std::collections::HashMap;

use anyhow::Result;
use lms_core::device::emulator::ScanSource;
use lms_core::telegram::RangeBits;
use lms_core::{Unit, Variant};
use lms_scene::{Bearings, NoiseModel, Pose, Scene};

use crate::synthetic::SceneArgs;

/// The unit the scene quantises in for a sensor unit (10 cm is drawn in
/// cm, then scaled).
fn range_unit(units: Unit) -> Unit {
    match units {
        Unit::Decimetre => Unit::Centimetre,
        other => other,
    }
}

/// The lms-scene bearings of a variant (ALGORITHM.md §1).
fn bearings(variant: Variant) -> Bearings {
    match variant {
        Variant::Fov180Res100 => Bearings::lms_180_1deg(),
        Variant::Fov180Res50 => Bearings::lms_180_half_deg(),
        Variant::Fov100Res100 => Bearings::lms_100_1deg(),
        Variant::Fov100Res50 => Bearings::lms_100_half_deg(),
        Variant::Fov100Res25 => Bearings::lms_100_quarter_deg(),
    }
}

/// Value words with 14 or 15 range bits: the range rounded to `units`,
/// at most the first error code ("above the maximum range"), no return as
/// the all-ones value ("not valid").
fn wide_raw(readings: &[lms_scene::Reading], units: Unit, bits: RangeBits) -> Vec<u16> {
    let per_metre = match units {
        Unit::Millimetre => 1000.0,
        Unit::Decimetre => 10.0,
        _ => 100.0,
    };
    let above = f64::from(bits.first_error_code());
    readings
        .iter()
        .map(|r| match r.metres() {
            Some(d) => (d * per_metre).round().clamp(0.0, above) as u16,
            None => bits.mask(),
        })
        .collect()
}

/// The built-in synthetic scene as a scan source (see the module docs).
#[derive(Debug)]
pub struct SceneSource {
    args: SceneArgs,
    scene: Scene,
    /// Per variant and units: `count` scans of raw values.
    draws: HashMap<(Variant, Unit), Vec<Vec<u16>>>,
    /// Scans handed out so far.
    sent: usize,
    /// Range bits of the values (the power-on measuring mode, `--range-mode`).
    bits: RangeBits,
}

impl SceneSource {
    /// The scene of `args` (checked like `host-bridge extract` checks them).
    pub fn new(args: &SceneArgs) -> Result<Self> {
        args.check()?;
        let (scene, _) = args.scene_and_rng();
        Ok(SceneSource {
            args: args.clone(),
            scene,
            draws: HashMap::new(),
            sent: 0,
            bits: RangeBits::Bits13,
        })
    }

    /// Values with `bits` range bits (14: 16 m modes, 15: 32 m modes; error
    /// codes below the all-ones value likewise, PROTOCOL.md §3).
    pub fn with_range_bits(mut self, bits: RangeBits) -> Self {
        self.bits = bits;
        self.draws.clear();
        self
    }

    /// The `count` noisy scans of a variant in these units (drawn on first
    /// use).
    fn draws(&mut self, variant: Variant, units: Unit) -> &[Vec<u16>] {
        let (args, scene, bits) = (&self.args, &self.scene, self.bits);
        self.draws.entry((variant, units)).or_insert_with(|| {
            let (_, mut rng) = args.scene_and_rng();
            let truth = scene.cast(&bearings(variant), Pose::IDENTITY);
            let unit = range_unit(units);
            let noise = NoiseModel::gaussian(args.noise_sigma)
                .with_quantisation(unit)
                .with_dropout(args.dropout);
            (0..args.count)
                .map(|_| {
                    let readings = truth.noisy(&noise, &mut rng);
                    if bits != RangeBits::Bits13 {
                        return wide_raw(&readings, units, bits);
                    }
                    let raw = lms_scene::to_raw(&readings, unit);
                    if units == Unit::Decimetre {
                        raw.into_iter()
                            .map(|v| if v < 8183 { (v + 5) / 10 } else { v })
                            .collect()
                    } else {
                        raw
                    }
                })
                .collect()
        })
    }

    /// The `count` scans (raw value words) this source sends, in turn, for
    /// `variant` in `units`: what a client through any number of hops must
    /// receive unchanged.
    pub fn scans_for(&mut self, variant: Variant, units: Unit) -> Vec<Vec<u16>> {
        self.draws(variant, units).to_vec()
    }

    /// One line for the log.
    pub fn describe(&self) -> String {
        format!(
            "scene {} (seed {}, {} noisy draws sent in turn, noise {} m, dropout {})",
            self.args.scene_name(),
            self.args.seed,
            self.args.count,
            self.args.noise_sigma,
            self.args.dropout
        )
    }
}

impl ScanSource for SceneSource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        let k = self.sent;
        self.sent = self.sent.wrapping_add(1);
        let draws = self.draws(variant, units);
        let Some(scan) = draws.get(k % draws.len().max(1)) else {
            return 0;
        };
        let n = scan.len().min(out.len());
        out[..n].copy_from_slice(&scan[..n]);
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_source_matches_extract_and_covers_all_variants() {
        let args = SceneArgs {
            count: 3,
            ..SceneArgs::default()
        };
        let mut src = SceneSource::new(&args).unwrap();
        let frames = crate::synthetic::frames(&args).unwrap();
        let mut out = [0u16; 401];
        for k in 0..4 {
            let n = src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut out[..361]);
            assert_eq!(n, 361);
            let f = &frames[k % 3].frame;
            for (j, (&v, &r)) in out.iter().zip(f.ranges()).enumerate() {
                if f.beams()[j].is_valid() {
                    assert_eq!(f32::from(v) / 1000.0, r, "scan {k} beam {j}");
                } else {
                    assert_eq!(v, 8191);
                }
            }
        }
        for v in Variant::ALL {
            for units in [Unit::Centimetre, Unit::Millimetre] {
                let n = src.next_scan(v, units, &mut out[..v.beams()]);
                assert_eq!(n, v.beams());
                let valid: Vec<_> = out[..n].iter().filter(|&&x| x < 8183).collect();
                assert!(valid.len() > n * 9 / 10, "{v:?} {units:?}");
                // The room is within 8 m: < 800 cm, < 8000 mm.
                let limit = if units == Unit::Millimetre { 8000 } else { 800 };
                assert!(valid.iter().all(|&&x| x > 0 && x < limit));
            }
        }
        // Straight ahead is beam 90 at 1° and beam 50 at 100°/1°: one ray.
        let mut a = [0u16; 181];
        let mut b = [0u16; 101];
        let quiet = SceneArgs {
            noise_sigma: 0.0,
            dropout: 0.0,
            ..args
        };
        let mut src = SceneSource::new(&quiet).unwrap();
        src.next_scan(Variant::Fov180Res100, Unit::Centimetre, &mut a);
        src.next_scan(Variant::Fov100Res100, Unit::Centimetre, &mut b);
        assert_eq!(a[90], b[50]);
        assert_eq!(&a[40..=140], &b[..]);
    }
}
