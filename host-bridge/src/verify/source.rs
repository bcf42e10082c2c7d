//! The scans played on the sensor line: [`PlaySource`], the selection of
//! a synthetic scene or a CARMEN log as an emulator scan source that logs
//! every draw, so that the scans coming back can be matched.

use anyhow::{ensure, Context, Result};
use lms_core::device::emulator::ScanSource;
use lms_core::{Frame, Invalid, Unit, Variant};

use super::VerifyArgs;
use crate::carmen;
use crate::resample;
use crate::synthetic;

/// Why a scan was drawn from the [`PlaySource`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tag {
    /// Before the client's stream was on (not counted).
    Warmup,
    /// Scan `k` of the selection.
    Play(usize),
    /// After the selection was exhausted (not counted).
    Extra,
}

/// One scan as the sensor side sent it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Drawn {
    /// Why it was drawn.
    pub tag: Tag,
    /// Unit of its values.
    pub units: Unit,
    /// Its value words, as in the `B0`.
    pub words: Vec<u16>,
}

/// The scans of the run as an emulator scan source: the selection in order,
/// each exactly once after [`PlaySource::arm`]; other scans of the
/// selection, cycling, before it and after the end. Every draw is logged
/// ([`PlaySource::draws`]) so that the scans coming back can be matched.
#[derive(Debug)]
pub struct PlaySource {
    frames: Vec<Frame>,
    /// Index of each frame in its log or scene, for messages.
    labels: Vec<usize>,
    /// The frames' variant.
    variant: Variant,
    armed: bool,
    next: usize,
    spare: usize,
    draws: Vec<Drawn>,
}

impl PlaySource {
    /// Play `frames` (all of one 180° variant; `labels` name them).
    pub fn new(frames: Vec<Frame>, labels: Vec<usize>) -> Result<Self> {
        let first = frames.first().context("no scans to play")?;
        let variant = Variant::from_beams(first.len())
            .with_context(|| format!("{} beams per scan", first.len()))?;
        ensure!(
            variant.fov_deg() == 180,
            "the scans are {}° wide: the co-processor runs 180°/0.5°, which a 100° scan cannot give",
            variant.fov_deg()
        );
        ensure!(
            frames.iter().all(|f| f.len() == first.len()),
            "all scans must have the same number of beams"
        );
        ensure!(labels.len() == frames.len(), "one label per frame");
        Ok(PlaySource {
            frames,
            labels,
            variant,
            armed: false,
            next: 0,
            spare: 0,
            draws: Vec::new(),
        })
    }

    /// Scans in the selection.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// `true` if there is nothing to play (never, by construction).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Keep only the first `n` scans.
    pub fn truncate(&mut self, n: usize) {
        self.frames.truncate(n.max(1));
        self.labels.truncate(n.max(1));
    }

    /// From now on draw the selection, in order.
    pub fn arm(&mut self) {
        self.armed = true;
    }

    /// Draw outside the selection again (warm-up scans) until the next
    /// [`PlaySource::arm`]: while the co-processor reboots.
    pub fn disarm(&mut self) {
        self.armed = false;
    }

    /// `true` once [`PlaySource::arm`] was called (and not disarmed since).
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Every scan drawn so far, in order.
    pub fn draws(&self) -> &[Drawn] {
        &self.draws
    }

    /// The log or scene index of scan `k` of the selection.
    pub fn label(&self, k: usize) -> usize {
        self.labels.get(k).copied().unwrap_or(k)
    }
}

impl ScanSource for PlaySource {
    fn next_scan(&mut self, variant: Variant, units: Unit, out: &mut [u16]) -> usize {
        let (tag, k) = if self.armed && self.next < self.frames.len() {
            self.next += 1;
            (Tag::Play(self.next - 1), self.next - 1)
        } else {
            self.spare += 1;
            let tag = if self.armed { Tag::Extra } else { Tag::Warmup };
            (tag, (self.spare - 1) % self.frames.len())
        };
        resample::frame_words(&self.frames[k], self.variant, variant, units, out);
        self.draws.push(Drawn {
            tag,
            units,
            words: out.to_vec(),
        });
        out.len()
    }

    fn supports(&self, variant: Variant) -> bool {
        resample::covers(self.variant, variant)
    }
}

/// The scans the options ask for, and a description for the log.
pub fn play_source(args: &VerifyArgs) -> Result<(PlaySource, String)> {
    let (mut source, about) = match &args.play.log {
        Some(path) => {
            // A log or a capture, streamed: only the selection is kept.
            let options = crate::input::ReadOptions {
                unit: crate::options::UnitArg::Auto,
                keep_damaged: false,
            };
            let mut file = crate::input::open_topic(path, options, args.play.topic.name())?;
            let range = args.frames.unwrap_or_default();
            let mut labels = Vec::new();
            let mut frames = Vec::new();
            while !range.is_past(file.read()) {
                let Some(scan) = file.next() else { break };
                let scan = scan?;
                if range.contains(scan.index) {
                    labels.push(scan.index);
                    frames.push(resample_carmen(scan.frame));
                }
            }
            file.warn_if_cut();
            ensure!(
                !frames.is_empty(),
                "{}: --frames {range} selects no frame (the file has {} frames)",
                path.display(),
                file.read()
            );
            let beams = frames[0].len();
            let about = format!(
                "{} frames {range} of {} ({} beams, {}{})",
                frames.len(),
                path.display(),
                beams,
                file.describe(),
                if beams == 361 {
                    ""
                } else {
                    "; resampled to 361 beams, nearest beam"
                }
            );
            let source = PlaySource::new(frames, labels)
                .with_context(|| format!("cannot play {}", path.display()))?;
            (source, about)
        }
        None => {
            let frames = synthetic::frames(&args.play.scene)?;
            let labels = frames.iter().map(|f| f.index).collect();
            let frames = frames.into_iter().map(|f| f.frame).collect();
            let about = format!(
                "synthetic scene {:?} (seed {}, {} frames, noise {} m, dropout {})",
                args.play.scene.scene,
                args.play.scene.seed,
                args.play.scene.count,
                args.play.scene.noise_sigma,
                args.play.scene.dropout
            )
            .to_lowercase();
            (PlaySource::new(frames, labels)?, about)
        }
    };
    if let Some(n) = args.scans {
        ensure!(n > 0, "--scans must be at least 1");
        ensure!(
            n <= source.len(),
            "--scans {n}: the selection has only {} scans (each is played once; use --count or --frames)",
            source.len()
        );
        source.truncate(n);
    }
    Ok((source, about))
}

/// CARMEN drops the last beam of 181/361-beam scans: put it back as "no
/// echo", so that 180 and 360 beams play as the LMS variants they come from.
fn resample_carmen(frame: Frame) -> Frame {
    let n = frame.len();
    let Some(variant) = carmen::variant_for_beams(n) else {
        return frame;
    };
    if variant.beams() == n {
        return frame;
    }
    let Ok(mut full) = Frame::new(variant.geometry(), variant.beams()) else {
        return frame;
    };
    for (j, (&r, beam)) in frame.ranges().iter().zip(frame.beams()).enumerate() {
        match beam {
            lms_core::Beam::Valid => full.set_metres(j, r),
            lms_core::Beam::Invalid(why) => full.set_invalid(j, *why),
        }
    }
    for j in n..variant.beams() {
        full.set_invalid(j, Invalid::NoEcho);
    }
    full
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::SceneArgs;
    use lms_core::telegram::{MeasuredValues, RangeBits};

    #[test]
    fn verify_source_plays_each_scan_once_after_arming() {
        let frames = synthetic::frames(&SceneArgs {
            count: 3,
            ..SceneArgs::default()
        })
        .unwrap();
        let labels = (10..13).collect();
        let mut src =
            PlaySource::new(frames.iter().map(|f| f.frame.clone()).collect(), labels).unwrap();
        let mut out = [0u16; 361];
        let v = Variant::Fov180Res50;
        src.next_scan(v, Unit::Millimetre, &mut out);
        src.arm();
        for _ in 0..4 {
            src.next_scan(v, Unit::Millimetre, &mut out);
        }
        let tags: Vec<Tag> = src.draws().iter().map(|d| d.tag).collect();
        assert_eq!(
            tags,
            [
                Tag::Warmup,
                Tag::Play(0),
                Tag::Play(1),
                Tag::Play(2),
                Tag::Extra
            ]
        );
        assert_eq!(src.label(2), 12);
        // Play(k) is frame k in whole mm, as `extract` reads it.
        let want =
            MeasuredValues::from_frame(&frames[1].frame, Unit::Millimetre, RangeBits::Bits13, 0);
        assert_eq!(src.draws()[2].words, want.values());
    }

    #[test]
    fn verify_carmen_frames_get_their_last_beam_back() {
        let frame = Frame::from_metres(Variant::Fov180Res50.geometry(), &[1.5; 360]).unwrap();
        let full = resample_carmen(frame);
        assert_eq!(full.len(), 361);
        assert!(!full.beams()[360].is_valid());
        assert_eq!(full.ranges()[359], 1.5);
        // 1°: every beam twice at 0.5° (odd beams take the next one).
        let coarse = Frame::from_metres(
            Variant::Fov180Res100.geometry(),
            &(0..181).map(|j| 1.0 + j as f32 / 100.0).collect::<Vec<_>>(),
        )
        .unwrap();
        let mut src = PlaySource::new(vec![coarse], vec![0]).unwrap();
        src.arm();
        let mut out = [0u16; 361];
        src.next_scan(Variant::Fov180Res50, Unit::Millimetre, &mut out);
        assert_eq!(&out[..4], &[1000, 1010, 1010, 1020]);
        assert_eq!(out[360], 2800);
        // 100° scans cannot give 180°.
        let narrow = Frame::from_metres(Variant::Fov100Res50.geometry(), &[1.0; 201]).unwrap();
        assert!(PlaySource::new(vec![narrow], vec![0]).is_err());
    }
}
