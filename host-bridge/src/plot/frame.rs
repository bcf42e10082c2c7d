//! One frame run through the pipeline with what the figures need
//! ([`FramePlot`]), and what the scan figure drew ([`ScanDrawn`]).

use anyhow::{anyhow, bail, ensure, Result};
use lms_core::{Extractor, Params, Trace};

use crate::extract::FrameRecord;
use crate::input::InputFrame;

/// `D` of every window after one pass.
#[derive(Clone, Debug, PartialEq)]
pub struct PassD {
    /// Pass number, from 1.
    pub pass: u16,
    /// `D` per window (`n − 2` entries, `+inf` where invalid).
    pub d: Vec<f32>,
}

/// One frame run through the pipeline, with everything the figures need.
#[derive(Clone, Debug)]
pub struct FramePlot {
    /// What the frame came from (for titles).
    pub source: String,
    /// Parameters of the run.
    pub params: Params,
    /// The record `extract` would write for the frame.
    pub record: FrameRecord,
    /// Bearing of every beam (rad, 0 = forward, positive to the left).
    pub bearings: Vec<f32>,
    /// `D` after the selected passes, ascending.
    pub passes: Vec<PassD>,
}

impl FramePlot {
    /// Run the extractor on `input`, keeping `D` after each pass in `passes`
    /// (all must be in `1..=params.iterations`).
    pub fn compute(
        source: String,
        input: &InputFrame,
        params: &Params,
        passes: &[u16],
    ) -> Result<Self> {
        params
            .validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        ensure!(!passes.is_empty(), "no pass selected for the D figure");
        if let Some(&p) = passes.iter().find(|&&p| p == 0 || p > params.iterations) {
            bail!(
                "--passes: pass {p} is not run (passes are 1..={}; set --iterations to run more)",
                params.iterations
            );
        }
        let mut ex = Extractor::new();
        let mut captured = Vec::with_capacity(passes.len());
        let valid = params
            .validate()
            .map_err(|e| anyhow!("invalid parameters: {e}"))?;
        let mut trace = Trace::new();
        ex.run_observed(&input.frame, &valid, &mut trace, |pass, d, _| {
            if passes.contains(&pass) {
                captured.push(PassD {
                    pass,
                    d: d.to_vec(),
                });
            }
        });
        let mut record = FrameRecord::from_run(input.index, &input.frame, &ex, &trace);
        record.pose = input.pose;
        let g = input.frame.geometry();
        Ok(FramePlot {
            source,
            params: *params,
            record,
            bearings: (0..input.frame.len()).map(|j| g.bearing(j)).collect(),
            passes: captured,
        })
    }

    pub(super) fn point(&self, j: usize, r: f32) -> (f64, f64) {
        let phi = f64::from(self.bearings[j]);
        let r = f64::from(r);
        (r * phi.cos(), r * phi.sin())
    }

    /// Valid raw points `(x, y)` (m).
    pub fn raw_points(&self) -> Vec<(f64, f64)> {
        self.record
            .ranges
            .iter()
            .enumerate()
            .filter_map(|(j, r)| r.map(|r| self.point(j, r)))
            .collect()
    }

    /// Smoothed points `(x, y)` of valid beams (m).
    pub fn smoothed_points(&self) -> Vec<(f64, f64)> {
        self.record
            .smoothed
            .iter()
            .enumerate()
            .filter_map(|(j, r)| r.map(|r| self.point(j, r)))
            .collect()
    }

    pub(super) fn params_text(&self) -> String {
        let p = &self.params;
        format!(
            "passes {}, q = {} m², τ = {}, σ = {} m, min points {}, max χ² {}",
            p.iterations, p.q, p.tau, p.sigma, p.min_points, p.max_chi2
        )
    }
}

/// What the scan figure drew.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ScanDrawn {
    /// Fitted lines drawn.
    pub lines: usize,
    /// Corners drawn (inside the view).
    pub corners: usize,
    /// Corners outside the view (not drawn).
    pub corners_out_of_view: usize,
    /// Edge points drawn.
    pub edges: usize,
    /// Factor the 2σ ellipses of well-conditioned corners are enlarged by.
    pub ellipse_scale_well: f64,
    /// Factor the 2σ ellipses of ill-conditioned corners are enlarged by.
    pub ellipse_scale_ill: f64,
    /// Metres per pixel, the same on both axes.
    pub metres_per_pixel: f64,
}
