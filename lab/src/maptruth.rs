//! Ground truth on real scans, from the map.
//!
//! The shared CARMEN logs carry SLAM-corrected laser poses. From them:
//!
//! 1. **Accumulate** every valid beam below [`TruthConfig::max_range`] of
//!    every frame in the world frame, into cells of [`TruthConfig::cell`]
//!    (5 cm). A cell is *occupied* if hits of at least
//!    [`TruthConfig::min_frames`] different frames fall into it (people and
//!    other passing things are seen in few frames); its point is the mean of
//!    its hits.
//! 2. **Extract the map's walls** by a Hough transform of the occupied
//!    cells (0.5° × 0.1 m bins, one vote per cell), strongest peak first:
//!    the cells within [`TruthConfig::inlier`] of the peak's line are cut at
//!    gaps over [`TruthConfig::max_gap`] into runs; a run at least
//!    [`TruthConfig::min_wall`] long with at least
//!    [`TruthConfig::min_density`] of its cells occupied is a wall, its line
//!    a consensus fit of its cells ([`consensus_tls`]). The peak's cells leave the
//!    transform; repeat until no peak has [`TruthConfig::min_votes`] cells.
//! 3. **Ray-cast** the walls into each frame: a beam is *on wall w* if its
//!    ray meets `w` (its extent widened by half a cell) and the measured
//!    hit is within [`TruthConfig::beam_tol`] of `w`'s line (so a person in
//!    front of a wall, or a hit past the map, is on no wall); of several
//!    such walls, the one whose line is nearest the hit. With
//!    [`TruthConfig::refine_pose`] the frame's pose is first registered to
//!    the walls ([`refine_pose`]; off by default: it changes nothing
//!    measurable, `cargo run --release -p lms-lab --example pose_refine`).
//!    Runs of beams on one wall, bridging at most
//!    [`TruthConfig::gap_beams`] beams on no wall (ALGORITHM.md §7.6's
//!    merge gap), are the frame's *true pieces*; the pieces with at least
//!    [`TruthConfig::min_beams`] (10) beams on the wall and at least
//!    [`TruthConfig::min_piece`] (0.3 m) long are *counted*. A
//!    piece's true line is the map wall's line in the sensor frame.
//! 4. **Verify** each piece against the frame ([`TruthConfig::verify`]): a
//!    total-least-squares fit to the piece's own on-wall hits must agree
//!    with the map line within the matching gates of [`crate::realtruth`]
//!    (|Δα| < 3°, |Δr| < 0.1 m). Where it does not, the map and this frame
//!    disagree — a pose off by degrees, a curved or irregular wall that the
//!    map cuts into straight runs, clutter standing against the wall inside
//!    the 0.1 m band — and a person looking at the frame cannot say which is
//!    right: such a piece is *unverified*, not counted, and its line for
//!    matching is its own hits' fit (a line that finds what the frame shows
//!    there is not false). Measured on every 5th frame of the shared logs:
//!    20 % of the pieces with ≥ 10 beams fail, 56 % of those shorter than 1 m
//!    (`cargo run --release -p lms-lab --example oracle_misses`).
//!
//! # The settled truth
//!
//! [`TruthConfig::settled`], the evaluation's truth ([`TruthConfig::legacy`]
//! is the above as it stands):
//!
//! * **Registered poses.** Every frame is registered to the map's walls
//!   ([`register`]: robust point-to-line ICP, a weak prior on the SLAM pose),
//!   the map is rebuilt from the registered poses and every frame registered
//!   to it again ([`register_log`], two rounds); each wall of a Hough line
//!   keeps its own line ([`TruthConfig::wall_own_line`]).
//! * **Leave-one-wall-out.** A piece's line is its map wall seen from the
//!   frame's pose registered without the beams on that wall's line
//!   ([`frame_truth_registered`]): the pose does not absorb the line it
//!   judges.
//! * **On-wall band 5 cm** ([`SETTLED_BEAM_TOL`]); a beam on two parallel
//!   walls of different lines within 15 cm is ambiguous, on neither
//!   ([`TruthConfig::ambiguous_within`]).
//! * **Every piece of ≥ 10 beams and ≥ 0.3 m counts** (no verification);
//!   shorter pieces and ambiguous beams are neutral, and the scoring leaves
//!   lines on no wall out of FalsePos as *unexplained*
//!   ([`TruthConfig::neutral_and_unexplained`],
//!   [`crate::realtruth::classify_lines`]).
//!
//! The check of it: a least-squares fit to each counted piece's own beams
//! (the oracle) matches 0.95 of the pieces over every frame of the shared
//! logs, 0.89–0.98 per log (`lms-lab truth`, docs/evaluation/real-truth.md).
//!
//! What this truth cannot show: walls the SLAM map itself misplaces (pose
//! error moves a piece's line by ~1–3 cm and ~0.3°, the figure of the
//! oracle in [`crate::realtruth`]), walls shorter than 0.5 m, and curved
//! walls (cut into straight runs or dropped). Glass and clutter seen in
//! fewer than three frames are on no wall.

use std::collections::{BinaryHeap, HashMap};

use host_bridge::carmen::Scan;

use crate::metrics::{centroid, tls};
use crate::realtruth::{gate_offsets, within_gates, ScoredLine};

/// Parameters of the map and of the per-frame truth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TruthConfig {
    /// Cell size of the accumulated map (m).
    pub cell: f64,
    /// A cell is occupied if hit in at least this many frames.
    pub min_frames: u32,
    /// Beams at or beyond this range are not used (m). The default, 40 m,
    /// is for callers that know nothing of the data; the real-log tools
    /// replace it with the log's own limit ([`TruthConfig::for_data`]),
    /// which also keeps out fill values such as the Acapulco log's ~50 m.
    pub max_range: f64,
    /// Hough angle bins over [0, π).
    pub angle_bins: usize,
    /// Hough distance bin (m).
    pub rho_bin: f64,
    /// Cells within this distance of a peak's line are its inliers (m).
    pub inlier: f64,
    /// Largest gap between consecutive cells of one wall (m).
    pub max_gap: f64,
    /// Shortest wall (m).
    pub min_wall: f64,
    /// Smallest fraction of a wall's length covered by occupied cells.
    pub min_density: f64,
    /// Fewest cells of a Hough peak.
    pub min_votes: u32,
    /// Largest distance of an on-wall hit from its wall's line (m).
    pub beam_tol: f64,
    /// Fewest on-wall beams of a counted piece.
    pub min_beams: usize,
    /// Shortest counted piece (m): fewer metres over ≥ 10 beams is a wall
    /// seen end-on or clutter near the sensor.
    pub min_piece: f64,
    /// Beams on no wall a piece may bridge.
    pub gap_beams: usize,
    /// Count only pieces whose own hits agree with the map line (step 4).
    pub verify: bool,
    /// Register each frame to the map's walls before ray-casting
    /// ([`refine_pose`]): the SLAM pose corrected by the frame's own hits.
    pub refine_pose: bool,
    /// Measure the matching's and the verification's Δr where the line is,
    /// at its middle, instead of at the foot of its normal (the default
    /// gate). A line far from its foot point misses the 0.1 m gate there
    /// with a sub-degree α error while lying on the wall ([`gate_offsets`];
    /// docs/DESIGN.md, "Open questions").
    pub range_gate_at_middle: bool,
    /// Rounds of registering every frame to the map's walls and rebuilding
    /// the map from the registered poses ([`register_log`]; 0: the SLAM
    /// poses as they are).
    pub register_rounds: usize,
    /// Take each piece's true line through a pose registered without the
    /// beams on its own map line ([`register`] with `skip`), so that the
    /// pose does not absorb the line it judges.
    pub leave_one_wall_out: bool,
    /// A beam whose ray meets two parallel map walls of different lines
    /// less than this apart (m) is ambiguous: on neither wall, neutral in
    /// the scoring (0: no beam is ambiguous).
    pub ambiguous_within: f64,
    /// The scoring's rules ([`crate::realtruth::score_frame`]): lines matched
    /// to uncounted pieces, and unmatched lines mostly on them or on
    /// ambiguous beams, are neutral; unmatched lines mostly on no wall are
    /// *unexplained*; both out of FalsePos. Without it every unmatched line
    /// is false.
    pub neutral_and_unexplained: bool,
    /// Each wall of a Hough line on its own line (a consensus fit to its
    /// cells), not on the line of all of them: runs of one Hough bin may
    /// differ by a degree or two, which the shared fit passes on to the
    /// shorter ones.
    pub wall_own_line: bool,
    /// The matching's overlap leaves out a line's ambiguous beams outside
    /// the piece ([`crate::realtruth::overlap_in`]): they are neutral, so
    /// they count neither for the match nor against it. Without it a line
    /// that follows a wall on through a stretch where the map holds two
    /// parallel walls counts that stretch as off the piece.
    pub overlap_without_ambiguous: bool,
}

impl Default for TruthConfig {
    fn default() -> Self {
        TruthConfig {
            cell: 0.05,
            min_frames: 3,
            max_range: 40.0,
            angle_bins: 360,
            rho_bin: 0.1,
            inlier: 0.075,
            max_gap: 0.3,
            min_wall: 0.5,
            min_density: 0.4,
            min_votes: 10,
            beam_tol: 0.1,
            min_beams: 10,
            min_piece: 0.3,
            gap_beams: 3,
            verify: true,
            refine_pose: false,
            range_gate_at_middle: false,
            register_rounds: 0,
            leave_one_wall_out: false,
            ambiguous_within: 0.0,
            neutral_and_unexplained: false,
            wall_own_line: false,
            overlap_without_ambiguous: false,
        }
    }
}

/// [`TruthConfig::beam_tol`] of the settled truth (m): with the frames
/// registered, hits on a wall lie within 2–3 cm of its map line; a band of
/// 0.1 m takes in clutter standing against walls, which tilts the fits of
/// short pieces (`cargo run --release -p lms-lab --example oracle_misses --
/// 5 settled 0.1`).
pub const SETTLED_BEAM_TOL: f64 = 0.05;

impl TruthConfig {
    /// The truth before registration ([`Default`]): SLAM poses, pieces
    /// verified against their own hits, Δr at the foot of the normal, every
    /// unmatched line false (`lms-lab truth --truth legacy`).
    pub fn legacy() -> Self {
        Self::default()
    }

    /// The evaluation's truth: every frame registered to the map's walls and
    /// the map rebuilt from the registered poses, twice; each piece's line
    /// through a pose registered without its own wall's beams; every piece
    /// of ≥ 10 beams and ≥ 0.3 m counted (no verification against its own
    /// hits); pieces of fewer beams and beams on two parallel walls within
    /// 15 cm neutral; Δr at the line's middle; unmatched lines mostly on no
    /// wall unexplained, not false.
    pub fn settled() -> Self {
        TruthConfig {
            verify: false,
            range_gate_at_middle: true,
            register_rounds: 2,
            leave_one_wall_out: true,
            ambiguous_within: 0.15,
            neutral_and_unexplained: true,
            beam_tol: SETTLED_BEAM_TOL,
            wall_own_line: true,
            ..Self::default()
        }
    }

    /// This truth over every range a log's extraction may use: beams up to
    /// `data_max_range` (m), the log's range limit from its data profile
    /// (`lms_core::DataProfile::max_range`: the mode's first error code, or
    /// the lowest fill value the log holds), instead of [`Self::max_range`].
    pub fn for_data(self, data_max_range: f32) -> Self {
        TruthConfig {
            max_range: f64::from(data_max_range),
            ..self
        }
    }
}

/// A wall of the map (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapWall {
    /// End points (m).
    pub a: [f64; 2],
    /// End points (m).
    pub b: [f64; 2],
    /// Normal direction of the line `x cos α + y sin α = ρ` (rad).
    pub alpha: f64,
    /// Signed distance of the line from the world origin (m).
    pub rho: f64,
    /// Occupied cells on it.
    pub cells: usize,
    /// Index of its line: collinear walls (one Hough peak) share it.
    pub line: usize,
}

impl MapWall {
    /// Length (m).
    pub fn length(&self) -> f64 {
        (self.b[0] - self.a[0]).hypot(self.b[1] - self.a[1])
    }
}

/// An occupied cell: mean hit and frames that hit it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapCell {
    /// Mean hit (m).
    pub p: [f64; 2],
    /// Frames with a hit in the cell.
    pub frames: u32,
}

/// The map of one log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Map {
    /// Occupied cells.
    pub cells: Vec<MapCell>,
    /// Walls, strongest first.
    pub walls: Vec<MapWall>,
}

/// World point of beam `j` of `scan` (laser pose, bearing from the frame).
pub fn world_hit(scan: &Scan, j: usize) -> [f64; 2] {
    world_hit_at(scan, j, scan.meta.pose)
}

/// World point of beam `j` of `scan` seen from the laser pose `pose`.
fn world_hit_at(scan: &Scan, j: usize, pose: [f64; 3]) -> [f64; 2] {
    let [x, y, th] = pose;
    let d = f64::from(scan.frame.ranges()[j]);
    let phi = th + f64::from(scan.frame.geometry().bearing(j));
    [x + d * phi.cos(), y + d * phi.sin()]
}

fn usable(scan: &Scan, j: usize, cfg: &TruthConfig) -> bool {
    let d = f64::from(scan.frame.ranges()[j]);
    scan.frame.beams()[j].is_valid() && d > 0.0 && d < cfg.max_range
}

/// Sum of hits, hits, frames, last frame of a cell being accumulated.
type CellSum = ([f64; 2], u32, u32, usize);

/// Step 1: the occupied cells of `scans`.
pub fn occupied_cells(scans: &[Scan], cfg: &TruthConfig) -> Vec<MapCell> {
    occupied_cells_at(scans, |k| scans[k].meta.pose, cfg)
}

/// [`occupied_cells`] with frame `k` seen from the laser pose `pose_of(k)`.
pub fn occupied_cells_at(
    scans: &[Scan],
    pose_of: impl Fn(usize) -> [f64; 3],
    cfg: &TruthConfig,
) -> Vec<MapCell> {
    let mut acc: HashMap<(i64, i64), CellSum> = HashMap::new();
    for (k, scan) in scans.iter().enumerate() {
        let pose = pose_of(k);
        for j in 0..scan.frame.len() {
            if !usable(scan, j, cfg) {
                continue;
            }
            let p = world_hit_at(scan, j, pose);
            let key = (
                (p[0] / cfg.cell).floor() as i64,
                (p[1] / cfg.cell).floor() as i64,
            );
            let e = acc.entry(key).or_insert(([0.0; 2], 0, 0, usize::MAX));
            e.0[0] += p[0];
            e.0[1] += p[1];
            e.1 += 1;
            if e.3 != k {
                e.2 += 1;
                e.3 = k;
            }
        }
    }
    let mut keys: Vec<_> = acc
        .into_iter()
        .filter(|(_, v)| v.2 >= cfg.min_frames)
        .collect();
    // Deterministic order (HashMap iteration is not).
    keys.sort_by_key(|(k, _)| *k);
    keys.into_iter()
        .map(|(_, (s, hits, frames, _))| MapCell {
            p: [s[0] / f64::from(hits), s[1] / f64::from(hits)],
            frames,
        })
        .collect()
}

/// A consensus fit of the points `pts` (sorted along their line): of the
/// lines through a point of the first third and one of the last third
/// (at most 15 × 15 pairs), the one with the most points within `tol`;
/// then [`tls`] of its points within `tol`, twice. Cells of a neighbouring
/// wall at a corner and stray hits do not tilt it.
pub fn consensus_tls(pts: &[[f64; 2]], tol: f64) -> (f64, f64) {
    let n = pts.len();
    if n < 6 {
        return tls(pts);
    }
    let third = n / 3;
    let step = third.div_ceil(15).max(1);
    let count = |a: f64, rho: f64| {
        pts.iter()
            .filter(|p| (p[0] * a.cos() + p[1] * a.sin() - rho).abs() <= tol)
            .count()
    };
    let mut best = (0, tls(pts));
    for i in (0..third).step_by(step) {
        for j in (n - third..n).step_by(step) {
            let (p, q) = (pts[i], pts[j]);
            let a = (q[1] - p[1]).atan2(q[0] - p[0]) + std::f64::consts::FRAC_PI_2;
            let rho = p[0] * a.cos() + p[1] * a.sin();
            let c = count(a, rho);
            if c > best.0 {
                best = (c, (a, rho));
            }
        }
    }
    let (mut a, mut rho) = best.1;
    for _ in 0..2 {
        let keep: Vec<[f64; 2]> = pts
            .iter()
            .copied()
            .filter(|p| (p[0] * a.cos() + p[1] * a.sin() - rho).abs() <= tol)
            .collect();
        if keep.len() < 2 {
            break;
        }
        (a, rho) = tls(&keep);
    }
    (a, rho)
}

struct Hough {
    bins: usize,
    rho_bin: f64,
    rho_min: f64,
    n_rho: usize,
    cos_sin: Vec<(f64, f64)>,
    acc: Vec<u32>,
}

impl Hough {
    fn new(cells: &[MapCell], cfg: &TruthConfig) -> Self {
        let reach = cells
            .iter()
            .map(|c| c.p[0].hypot(c.p[1]))
            .fold(0.0, f64::max)
            + 1.0;
        let n_rho = (2.0 * reach / cfg.rho_bin).ceil() as usize + 1;
        let cos_sin = (0..cfg.angle_bins)
            .map(|k| {
                let t = k as f64 * std::f64::consts::PI / cfg.angle_bins as f64;
                (t.cos(), t.sin())
            })
            .collect();
        let mut h = Hough {
            bins: cfg.angle_bins,
            rho_bin: cfg.rho_bin,
            rho_min: -reach,
            n_rho,
            cos_sin,
            acc: vec![0; cfg.angle_bins * n_rho],
        };
        for c in cells {
            h.vote(c.p, true);
        }
        h
    }

    fn vote(&mut self, p: [f64; 2], add: bool) {
        for k in 0..self.bins {
            let (c, s) = self.cos_sin[k];
            let i = ((p[0] * c + p[1] * s - self.rho_min) / self.rho_bin).round() as usize;
            let cell = &mut self.acc[k * self.n_rho + i.min(self.n_rho - 1)];
            *cell = if add {
                *cell + 1
            } else {
                cell.saturating_sub(1)
            };
        }
    }

    fn line(&self, idx: usize) -> (f64, f64) {
        let k = idx / self.n_rho;
        let i = idx % self.n_rho;
        (
            k as f64 * std::f64::consts::PI / self.bins as f64,
            self.rho_min + i as f64 * self.rho_bin,
        )
    }
}

/// The cells of `idx` (alive, within `tol` of `(α, ρ)`).
fn inliers(cells: &[MapCell], alive: &[bool], alpha: f64, rho: f64, tol: f64) -> Vec<usize> {
    let (c, s) = (alpha.cos(), alpha.sin());
    (0..cells.len())
        .filter(|&i| alive[i] && (cells[i].p[0] * c + cells[i].p[1] * s - rho).abs() <= tol)
        .collect()
}

/// The walls among the inlier cells `idx` of the line `(α, ρ)`: runs cut at
/// gaps, all on one consensus line of their cells (collinear walls are one
/// line, as in the synthetic truth); `line` is that line's index.
fn runs_to_walls(
    cells: &[MapCell],
    idx: &[usize],
    alpha: f64,
    line: usize,
    cfg: &TruthConfig,
) -> Vec<MapWall> {
    let (c, s) = (alpha.cos(), alpha.sin());
    let along = |p: [f64; 2]| -p[0] * s + p[1] * c;
    let mut order: Vec<(f64, usize)> = idx.iter().map(|&i| (along(cells[i].p), i)).collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut runs: Vec<&[(f64, usize)]> = Vec::new();
    let mut start = 0;
    for k in 1..=order.len() {
        if k < order.len() && order[k].0 - order[k - 1].0 <= cfg.max_gap {
            continue;
        }
        let run = &order[start..k];
        start = k;
        let extent = run[run.len() - 1].0 - run[0].0 + cfg.cell;
        if extent >= cfg.min_wall && (run.len() as f64) * cfg.cell >= cfg.min_density * extent {
            runs.push(run);
        }
    }
    let pts: Vec<[f64; 2]> = runs
        .iter()
        .flat_map(|r| r.iter().map(|&(_, i)| cells[i].p))
        .collect();
    if pts.is_empty() {
        return Vec::new();
    }
    let shared = consensus_tls(&pts, 0.5 * cfg.cell);
    runs.iter()
        .map(|run| {
            let (a, rho) = if cfg.wall_own_line && runs.len() > 1 {
                let own: Vec<[f64; 2]> = run.iter().map(|&(_, i)| cells[i].p).collect();
                own_wall_line(&own, shared, cfg)
            } else {
                shared
            };
            let (ca, sa) = (a.cos(), a.sin());
            let t = |p: &[f64; 2]| -p[0] * sa + p[1] * ca;
            let at = |t: f64| [rho * ca - t * sa, rho * sa + t * ca];
            let (t0, t1) = run.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &(_, i)| {
                (lo.min(t(&cells[i].p)), hi.max(t(&cells[i].p)))
            });
            MapWall {
                a: at(t0 - 0.5 * cfg.cell),
                b: at(t1 + 0.5 * cfg.cell),
                alpha: a,
                rho,
                cells: run.len(),
                line,
            }
        })
        .collect()
}

/// The line of one wall of a Hough line from its own cells `pts` (a
/// consensus fit, oriented as `shared`), or `shared` if its cells are too
/// few to fix a direction ([`TruthConfig::wall_own_line`]).
fn own_wall_line(pts: &[[f64; 2]], shared: (f64, f64), cfg: &TruthConfig) -> (f64, f64) {
    if (pts.len() as u32) < cfg.min_votes {
        return shared;
    }
    let (mut a, mut rho) = consensus_tls(pts, 0.5 * cfg.cell);
    if (a - shared.0).cos() < 0.0 {
        a += std::f64::consts::PI;
        rho = -rho;
    }
    (lms_scene::wrap_angle(a), rho)
}

/// Step 2: the walls of the occupied `cells` (see the module docs).
pub fn extract_walls(cells: &[MapCell], cfg: &TruthConfig) -> Vec<MapWall> {
    if cells.is_empty() {
        return Vec::new();
    }
    let mut h = Hough::new(cells, cfg);
    let mut alive = vec![true; cells.len()];
    let mut heap: BinaryHeap<(u32, std::cmp::Reverse<usize>)> = h
        .acc
        .iter()
        .enumerate()
        .filter(|(_, &v)| v >= cfg.min_votes)
        .map(|(i, &v)| (v, std::cmp::Reverse(i)))
        .collect();
    let mut walls = Vec::new();
    while let Some((v, std::cmp::Reverse(idx))) = heap.pop() {
        let now = h.acc[idx];
        if now != v {
            if now >= cfg.min_votes {
                heap.push((now, std::cmp::Reverse(idx)));
            }
            continue;
        }
        let (a0, r0) = h.line(idx);
        let first = inliers(cells, &alive, a0, r0, cfg.inlier);
        let pts: Vec<[f64; 2]> = first.iter().map(|&i| cells[i].p).collect();
        let (a, rho) = if pts.len() >= 2 { tls(&pts) } else { (a0, r0) };
        let mut idx_in = inliers(cells, &alive, a, rho, cfg.inlier);
        if idx_in.len() < first.len() {
            idx_in = first;
        }
        if (idx_in.len() as u32) < cfg.min_votes {
            // The peak's cells are spread over neighbouring bins: retire it.
            h.acc[idx] = 0;
            continue;
        }
        let line = walls.last().map_or(0, |w: &MapWall| w.line + 1);
        walls.extend(runs_to_walls(cells, &idx_in, a, line, cfg));
        for &i in &idx_in {
            alive[i] = false;
            h.vote(cells[i].p, false);
        }
        if h.acc[idx] == now {
            h.acc[idx] = 0;
        }
        heap.push((h.acc[idx], std::cmp::Reverse(idx)));
    }
    walls
}

/// Steps 1 and 2 for a log.
pub fn build_map(scans: &[Scan], cfg: &TruthConfig) -> Map {
    let cells = occupied_cells(scans, cfg);
    let walls = extract_walls(&cells, cfg);
    Map { cells, walls }
}

/// A true piece of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    /// Index of the map wall of its first beam (collinear walls of one
    /// line continue a piece).
    pub wall: usize,
    /// Index of the map line (the key of repeatability and fragmentation).
    pub line: usize,
    /// Normal direction in the sensor frame (rad), as `lms_core::Line`.
    pub alpha: f64,
    /// Distance from the sensor (m), ≥ 0.
    pub r: f64,
    /// First beam.
    pub first: usize,
    /// Last beam (inclusive).
    pub last: usize,
    /// Beams on the wall.
    pub beams: usize,
    /// Distance between the first and last on-wall hits along the wall (m).
    pub length: f64,
    /// Normal direction of the TLS fit to the piece's own on-wall hits
    /// in the sensor frame (rad).
    pub own_alpha: f64,
    /// Distance of that fit (m), ≥ 0.
    pub own_r: f64,
    /// Centroid of the piece's own on-wall hits in the sensor frame (m):
    /// the middle of the fit above.
    pub own_middle: [f64; 2],
    /// Lines are matched to it with Δr at their middle
    /// ([`TruthConfig::range_gate_at_middle`], [`gate_offsets`]).
    pub gate_at_middle: bool,
    /// The own fit agrees with the map line (step 4).
    pub verified: bool,
    /// At least `min_beams` beams on the wall, `min_piece` long and, with
    /// [`TruthConfig::verify`], verified.
    pub counted: bool,
}

impl Piece {
    /// A counted, verified piece of the beams `beams` on the map line
    /// `(alpha, r)` (rad, m), its own fit on that line, `length` m long:
    /// for hand-made cases.
    pub fn hand_made(
        beams: std::ops::RangeInclusive<usize>,
        (alpha, r): (f64, f64),
        length: f64,
    ) -> Piece {
        let (first, last) = (*beams.start(), *beams.end());
        Piece {
            wall: first,
            line: first,
            alpha,
            r,
            first,
            last,
            beams: last - first + 1,
            length,
            own_alpha: alpha,
            own_r: r,
            own_middle: [r * alpha.cos(), r * alpha.sin()],
            gate_at_middle: false,
            verified: true,
            counted: true,
        }
    }
}

impl Piece {
    /// The line a method's line is matched against: the map's where the
    /// frame confirms it or the piece is counted anyway (without
    /// [`TruthConfig::verify`]), else the frame's own hits' fit.
    pub fn reference(&self) -> (f64, f64) {
        if self.verified || self.counted {
            (self.alpha, self.r)
        } else {
            (self.own_alpha, self.own_r)
        }
    }
}

/// TLS fit `(α, r)`, r ≥ 0, to the hits of beams `first..=last` on map
/// line `line`, in the sensor frame, and the hits' centroid.
pub fn own_fit(
    scan: &Scan,
    on_wall: &[Option<usize>],
    line: usize,
    span: (usize, usize),
) -> (f64, f64, [f64; 2]) {
    let g = scan.frame.geometry();
    let r = scan.frame.ranges();
    let pts: Vec<[f64; 2]> = (span.0..=span.1)
        .filter(|&j| on_wall[j] == Some(line))
        .map(|j| {
            let (d, phi) = (f64::from(r[j]), f64::from(g.bearing(j)));
            [d * phi.cos(), d * phi.sin()]
        })
        .collect();
    let (mut a, mut rho) = tls(&pts);
    if rho < 0.0 {
        rho = -rho;
        a += std::f64::consts::PI;
    }
    (lms_scene::wrap_angle(a), rho, centroid(&pts))
}

/// The truth of one frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTruth {
    /// Per beam: the map line (of the wall) it is on.
    pub on_wall: Vec<Option<usize>>,
    /// True pieces in beam order.
    pub pieces: Vec<Piece>,
    /// Per beam: on two parallel map walls within
    /// [`TruthConfig::ambiguous_within`] (on neither in `on_wall`); empty
    /// for none.
    pub ambiguous: Vec<bool>,
    /// Score with neutral and unexplained lines
    /// ([`TruthConfig::neutral_and_unexplained`]).
    pub neutral_and_unexplained: bool,
    /// [`TruthConfig::overlap_without_ambiguous`].
    pub overlap_without_ambiguous: bool,
}

/// The wall `w`'s line in the sensor frame at `pose`: `(α, r)`, r ≥ 0.
pub fn line_in_sensor(w: &MapWall, pose: [f64; 3]) -> (f64, f64) {
    let [x, y, th] = pose;
    let mut alpha = w.alpha - th;
    let mut r = w.rho - (x * w.alpha.cos() + y * w.alpha.sin());
    if r < 0.0 {
        r = -r;
        alpha += std::f64::consts::PI;
    }
    (lms_scene::wrap_angle(alpha), r)
}

/// Ray `o + t·u` against the segment `w`, extended by `ext` at both ends:
/// the ray parameter `t > 0` if it meets it.
fn ray_hit(o: [f64; 2], u: [f64; 2], w: &MapWall, ext: f64) -> Option<f64> {
    let e = [w.b[0] - w.a[0], w.b[1] - w.a[1]];
    let len = e[0].hypot(e[1]);
    let den = u[0] * e[1] - u[1] * e[0];
    if den.abs() < 1e-12 || len <= 0.0 {
        return None;
    }
    let d = [w.a[0] - o[0], w.a[1] - o[1]];
    let t = (d[0] * e[1] - d[1] * e[0]) / den;
    let s = (d[0] * u[1] - d[1] * u[0]) / den;
    let margin = ext / len;
    (t > 0.0 && s >= -margin && s <= 1.0 + margin).then_some(t)
}

/// Step 3 for one beam seen from `pose`: the wall it is on, and the hit's
/// signed distance from that wall's line (m).
fn beam_wall(
    scan: &Scan,
    j: usize,
    pose: [f64; 3],
    walls: &[MapWall],
    near: &[usize],
    cfg: &TruthConfig,
) -> Option<(usize, f64)> {
    if !usable(scan, j, cfg) {
        return None;
    }
    let [x, y, th] = pose;
    let phi = th + f64::from(scan.frame.geometry().bearing(j));
    let u = [phi.cos(), phi.sin()];
    let p = world_hit_at(scan, j, pose);
    let mut best: Option<(usize, f64)> = None;
    for &w in near {
        let wall = &walls[w];
        if ray_hit([x, y], u, wall, 0.5 * cfg.cell).is_none() {
            continue;
        }
        let e = p[0] * wall.alpha.cos() + p[1] * wall.alpha.sin() - wall.rho;
        if e.abs() <= cfg.beam_tol && best.is_none_or(|(_, be)| e.abs() < be.abs()) {
            best = Some((w, e));
        }
    }
    best
}

/// Parallel map walls (degrees): their normals closer than this.
const AMBIGUOUS_PARALLEL_DEG: f64 = 5.0;

/// Whether the ray of beam `j` seen from `pose` meets, besides `w`, a wall of
/// another map line parallel to `w` whose crossing with the ray lies within
/// [`TruthConfig::ambiguous_within`] of `w`'s line: the map holds one
/// surface twice there, and which of the two the beam is on is unknowable.
fn ambiguous_beam(
    scan: &Scan,
    j: usize,
    pose: [f64; 3],
    walls: &[MapWall],
    near: &[usize],
    w: usize,
    cfg: &TruthConfig,
) -> bool {
    if cfg.ambiguous_within <= 0.0 {
        return false;
    }
    let [x, y, th] = pose;
    let phi = th + f64::from(scan.frame.geometry().bearing(j));
    let u = [phi.cos(), phi.sin()];
    let own = &walls[w];
    near.iter().any(|&v| {
        let other = &walls[v];
        if other.line == own.line {
            return false;
        }
        let da = lms_scene::wrap_angle(2.0 * (other.alpha - own.alpha)).abs() / 2.0;
        if da > AMBIGUOUS_PARALLEL_DEG.to_radians() {
            return false;
        }
        let Some(t) = ray_hit([x, y], u, other, 0.5 * cfg.cell) else {
            return false;
        };
        let q = [x + t * u[0], y + t * u[1]];
        (q[0] * own.alpha.cos() + q[1] * own.alpha.sin() - own.rho).abs() < cfg.ambiguous_within
    })
}

/// Per beam of `scan`, the walls of `near` its ray may meet near its hit
/// while the pose moves by up to a few decimetres from `pose`: what
/// [`beam_wall`] need look at during a registration.
fn beam_candidates(
    scan: &Scan,
    pose: [f64; 3],
    walls: &[MapWall],
    near: &[usize],
    cfg: &TruthConfig,
) -> Vec<Vec<usize>> {
    const SLACK: f64 = 0.3;
    let [x, y, th] = pose;
    (0..scan.frame.len())
        .map(|j| {
            if !usable(scan, j, cfg) {
                return Vec::new();
            }
            let phi = th + f64::from(scan.frame.geometry().bearing(j));
            let u = [phi.cos(), phi.sin()];
            let p = world_hit_at(scan, j, pose);
            near.iter()
                .copied()
                .filter(|&w| {
                    let wall = &walls[w];
                    let e = p[0] * wall.alpha.cos() + p[1] * wall.alpha.sin() - wall.rho;
                    e.abs() <= cfg.beam_tol.max(cfg.ambiguous_within) + SLACK
                        && ray_hit([x, y], u, wall, 0.5 * cfg.cell + SLACK).is_some()
                })
                .collect()
        })
        .collect()
}

/// Registration: a hit's scatter about its wall (m), the scale of the
/// Cauchy weight `1/(1 + (e/s)²)` that takes clutter against a wall out.
const REFINE_SCATTER: f64 = 0.03;
/// Registration prior: the SLAM pose's standard deviation in x and y (m).
const REFINE_PRIOR_XY: f64 = 0.1;
/// Registration prior: the SLAM pose's standard deviation in heading (rad, 2°).
const REFINE_PRIOR_TH: f64 = 0.035;
/// Gauss–Newton steps of the registration (each re-assigns the beams).
const REFINE_STEPS: usize = 5;

/// The laser pose of `scan` registered to the map's walls (step 3a): from
/// the SLAM pose, Gauss–Newton steps on the hits' distances to the walls
/// their beams meet (assigned as in step 3, at the current pose), each
/// hit Cauchy-weighted at 3 cm (`REFINE_SCATTER`), with the SLAM pose as a
/// prior (0.1 m, 2°: `REFINE_PRIOR_XY`, `REFINE_PRIOR_TH`) so that what the frame does not
/// constrain (along a corridor) stays where SLAM put it. A frame of one
/// SLAM run is a few centimetres and tenths of a degree off the map the run
/// built; at the matching gates' scale (3°, 0.1 m) that error moves every
/// piece of the frame alike, which a registration of the whole frame — three
/// numbers from hundreds of hits — removes without fitting any one piece.
pub fn refine_pose(scan: &Scan, walls: &[MapWall], near: &[usize], cfg: &TruthConfig) -> [f64; 3] {
    let prior = scan.meta.pose;
    let beams = 0..scan.frame.len();
    gauss_newton(scan, walls, (prior, prior), false, |pose| {
        beams
            .clone()
            .filter_map(move |j| beam_wall(scan, j, pose, walls, near, cfg).map(|(w, e)| (j, w, e)))
            .collect()
    })
}

/// Gauss–Newton steps of a registration from `start` with `prior` as a
/// prior (`REFINE_PRIOR_XY`, `REFINE_PRIOR_TH`; the heading's difference
/// wrapped with `wrap`): `hits(pose)` gives the beams used at a pose as
/// `(beam, wall, signed distance)`, each Cauchy-weighted at
/// `REFINE_SCATTER`.
fn gauss_newton(
    scan: &Scan,
    walls: &[MapWall],
    (prior, start): ([f64; 3], [f64; 3]),
    wrap: bool,
    mut hits: impl FnMut([f64; 3]) -> Vec<(usize, usize, f64)>,
) -> [f64; 3] {
    let g = scan.frame.geometry();
    let mut pose = start;
    let info = [
        REFINE_PRIOR_XY.powi(-2),
        REFINE_PRIOR_XY.powi(-2),
        REFINE_PRIOR_TH.powi(-2),
    ];
    for _ in 0..REFINE_STEPS {
        let mut h = [[0.0f64; 3]; 3];
        let mut b = [0.0f64; 3];
        for k in 0..3 {
            h[k][k] = info[k];
            b[k] = -info[k] * (pose[k] - prior[k]);
        }
        if wrap {
            b[2] = -info[2] * lms_scene::wrap_angle(pose[2] - prior[2]);
        }
        for (j, w, e) in hits(pose) {
            let (ca, sa) = (walls[w].alpha.cos(), walls[w].alpha.sin());
            let d = f64::from(scan.frame.ranges()[j]);
            let phi = pose[2] + f64::from(g.bearing(j));
            let jac = [ca, sa, d * (-phi.sin() * ca + phi.cos() * sa)];
            let wgt = 1.0 / (1.0 + (e / REFINE_SCATTER).powi(2)) / REFINE_SCATTER.powi(2);
            for r in 0..3 {
                for c in 0..3 {
                    h[r][c] += wgt * jac[r] * jac[c];
                }
                b[r] -= wgt * jac[r] * e;
            }
        }
        let Some(step) = crate::variants::solve3(h, b) else {
            break;
        };
        for k in 0..3 {
            pose[k] += step[k];
        }
        if step[0].hypot(step[1]) < 1e-5 && step[2].abs() < 1e-6 {
            break;
        }
    }
    pose
}

/// Walls with a point within `reach` of `o`.
fn walls_near(walls: &[MapWall], o: [f64; 2], reach: f64) -> Vec<usize> {
    (0..walls.len())
        .filter(|&w| {
            let (a, b) = (walls[w].a, walls[w].b);
            let e = [b[0] - a[0], b[1] - a[1]];
            let l2 = (e[0] * e[0] + e[1] * e[1]).max(1e-12);
            let s = (((o[0] - a[0]) * e[0] + (o[1] - a[1]) * e[1]) / l2).clamp(0.0, 1.0);
            let q = [a[0] + s * e[0] - o[0], a[1] + s * e[1] - o[1]];
            q[0].hypot(q[1]) <= reach
        })
        .collect()
}

/// Step 3: the true pieces of `scan` against `map`.
pub fn frame_truth(scan: &Scan, map: &Map, cfg: &TruthConfig) -> FrameTruth {
    let [x, y, _] = scan.meta.pose;
    let near = walls_near(&map.walls, [x, y], cfg.max_range);
    let pose = if cfg.refine_pose {
        refine_pose(scan, &map.walls, &near, cfg)
    } else {
        scan.meta.pose
    };
    truth_at(scan, map, cfg, pose, |_| &near, |_| pose)
}

/// The laser pose of `scan` registered to `walls` by robust point-to-line
/// ICP: from `start`, Gauss–Newton steps on the hits' distances to the
/// walls their beams are on (re-assigned at each step among `cands`, the
/// beams on two parallel walls left out), each hit Cauchy-weighted at
/// 3 cm, with `prior` (the SLAM pose) a weak prior of 0.1 m and 2° so
/// that what the frame does not constrain stays where SLAM put it. With
/// `skip`, the beams on that map line are left out: the pose that judges
/// that line does not absorb it.
pub fn register(
    scan: &Scan,
    walls: &[MapWall],
    cands: &[Vec<usize>],
    cfg: &TruthConfig,
    (prior, start): ([f64; 3], [f64; 3]),
    skip: Option<usize>,
) -> [f64; 3] {
    gauss_newton(scan, walls, (prior, start), true, |pose| {
        let mut hits = Vec::new();
        for (j, near) in cands.iter().enumerate() {
            let Some((w, e)) = beam_wall(scan, j, pose, walls, near, cfg) else {
                continue;
            };
            if skip == Some(walls[w].line) || ambiguous_beam(scan, j, pose, walls, near, w, cfg) {
                continue;
            }
            hits.push((j, w, e));
        }
        hits
    })
}

/// The walls near `pose` and, per beam, the walls it may be on
/// ([`register`]'s `cands`).
pub fn candidates_at(
    scan: &Scan,
    walls: &[MapWall],
    pose: [f64; 3],
    cfg: &TruthConfig,
) -> Vec<Vec<usize>> {
    let near = walls_near(walls, [pose[0], pose[1]], cfg.max_range);
    beam_candidates(scan, pose, walls, &near, cfg)
}

/// Every frame of `scans` registered to `map` ([`register`], the SLAM pose
/// the prior, `start` the first guess), and the map rebuilt from the
/// registered poses, [`TruthConfig::register_rounds`] times; the map is
/// rebuilt after each round but the last. Returns the map and the poses
/// registered to it.
pub fn register_log(scans: &[Scan], map: Map, cfg: &TruthConfig) -> (Map, Vec<[f64; 3]>) {
    let mut poses: Vec<[f64; 3]> = scans.iter().map(|s| s.meta.pose).collect();
    let mut map = map;
    for round in 0..cfg.register_rounds {
        if round > 0 {
            let cells = occupied_cells_at(scans, |k| poses[k], cfg);
            let walls = extract_walls(&cells, cfg);
            map = Map { cells, walls };
        }
        poses = scans
            .iter()
            .zip(&poses)
            .map(|(scan, &start)| {
                let cands = candidates_at(scan, &map.walls, start, cfg);
                register(scan, &map.walls, &cands, cfg, (scan.meta.pose, start), None)
            })
            .collect();
    }
    (map, poses)
}

/// Step 3 for `scan` seen from the registered `pose`: the beams assigned at
/// `pose`, and with [`TruthConfig::leave_one_wall_out`] each piece's line
/// taken through the pose registered without its own map line's beams.
pub fn frame_truth_registered(
    scan: &Scan,
    map: &Map,
    pose: [f64; 3],
    cfg: &TruthConfig,
) -> FrameTruth {
    let cands = candidates_at(scan, &map.walls, pose, cfg);
    let mut cache: HashMap<usize, [f64; 3]> = HashMap::new();
    truth_at(
        scan,
        map,
        cfg,
        pose,
        |j| &cands[j],
        |line| {
            if !cfg.leave_one_wall_out {
                return pose;
            }
            *cache.entry(line).or_insert_with(|| {
                register(
                    scan,
                    &map.walls,
                    &cands,
                    cfg,
                    (scan.meta.pose, pose),
                    Some(line),
                )
            })
        },
    )
}

/// Step 3 at `pose`: beam `j` looks for its wall among `near_of(j)`; a
/// piece's line is the map line seen from `line_pose(line)`.
fn truth_at<'a>(
    scan: &Scan,
    map: &Map,
    cfg: &TruthConfig,
    pose: [f64; 3],
    near_of: impl Fn(usize) -> &'a [usize],
    mut line_pose: impl FnMut(usize) -> [f64; 3],
) -> FrameTruth {
    let mut ambiguous = vec![false; scan.frame.len()];
    let walls: Vec<Option<usize>> = (0..scan.frame.len())
        .map(|j| {
            let near = near_of(j);
            let (w, _) = beam_wall(scan, j, pose, &map.walls, near, cfg)?;
            if ambiguous_beam(scan, j, pose, &map.walls, near, w, cfg) {
                ambiguous[j] = true;
                return None;
            }
            Some(w)
        })
        .collect();
    let on_wall: Vec<Option<usize>> = walls.iter().map(|w| w.map(|w| map.walls[w].line)).collect();
    let mut pieces = Vec::new();
    let mut j = 0;
    while j < on_wall.len() {
        let Some(w) = walls[j] else {
            j += 1;
            continue;
        };
        let (first, mut last, mut beams) = (j, j, 1);
        let mut k = j + 1;
        while k < on_wall.len() && k <= last + 1 + cfg.gap_beams {
            match on_wall[k] {
                Some(v) if v == map.walls[w].line => {
                    last = k;
                    beams += 1;
                }
                Some(_) => break,
                None => {}
            }
            k += 1;
        }
        let wall = &map.walls[w];
        let (alpha, r) = line_in_sensor(wall, line_pose(wall.line));
        let t = |p: [f64; 2]| -p[0] * wall.alpha.sin() + p[1] * wall.alpha.cos();
        let length = (t(world_hit_at(scan, last, pose)) - t(world_hit_at(scan, first, pose))).abs();
        let (own_alpha, own_r, own_middle) = own_fit(scan, &on_wall, wall.line, (first, last));
        let own = ScoredLine {
            alpha: own_alpha,
            r: own_r,
            first,
            last,
            middle: own_middle,
        };
        let verified = within_gates(gate_offsets(&own, (alpha, r), cfg.range_gate_at_middle));
        pieces.push(Piece {
            wall: w,
            line: wall.line,
            alpha,
            r,
            first,
            last,
            beams,
            length,
            own_alpha,
            own_r,
            own_middle,
            gate_at_middle: cfg.range_gate_at_middle,
            verified,
            counted: beams >= cfg.min_beams && length >= cfg.min_piece && (verified || !cfg.verify),
        });
        j = last + 1;
    }
    let ambiguous = if ambiguous.contains(&true) {
        ambiguous
    } else {
        Vec::new()
    };
    FrameTruth {
        on_wall,
        pieces,
        ambiguous,
        neutral_and_unexplained: cfg.neutral_and_unexplained,
        overlap_without_ambiguous: cfg.overlap_without_ambiguous,
    }
}
