use anyhow::Result;
use lms_core::{Extractor, Params};
use lms_lab::baselines::run_core;
use lms_lab::metrics::{scan_truth, score_lines, Gates, Tally};
use lms_lab::scenes::{sample, Family, NoiseSpec};
use lms_lab::sweep::Adjust;

fn main() -> Result<()> {
    let scans: usize = std::env::args().nth(1).map_or(Ok(200), |s| s.parse())?;
    let variants: Vec<(&str, Adjust)> = vec![
        ("defaults", |p| p),
        ("footprint 0", |p| p.with_footprint(0.0)),
        ("turn_offsets off", |p| p.with_turn_offsets(false)),
        ("same_turn off", |p| p.with_same_turn_windows(false)),
        ("anchor inf", |p| p.with_merge_anchor_gate(f32::INFINITY)),
        ("bridge off", |p| p.with_bridge_merge(false)),
        ("collinear off", |p| p.with_merge_collinear(false)),
        ("own beams off", |p| p.with_merge_own_beams(false)),
        ("merge off", |p| p.with_merge(false)),
        ("v3.2", |_| Params::V3_2),
        ("v3.1", |_| Params::V3_1),
        ("v2", |_| Params::V2),
    ];
    let only_defaults = std::env::var("ALL").is_err();
    let variants: Vec<(&str, Adjust)> = if only_defaults {
        variants[..1].to_vec()
    } else {
        variants
    };
    let gates = Gates::default();
    let mut ex = Extractor::new();
    println!("| σ | variant | TruePos | FalsePos | σΔα/CRB | σΔr/CRB | gross | α/r w/o gross | NEES median |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for sigma in [0.01, 0.02] {
        let mut tallies = vec![Tally::default(); variants.len()];
        for family in Family::ALL {
            for k in 0..scans {
                let s = sample(
                    family,
                    k,
                    1,
                    NoiseSpec {
                        sigma,
                        dropout: 0.01,
                    },
                )?;
                for (v, t) in variants.iter().zip(tallies.iter_mut()) {
                    let params = (v.1)(Params::DEFAULT).with_sigma(sigma as f32);
                    let truth = scan_truth(&s.truth, &s.scene, &params, sigma, &gates);
                    let x = run_core(&mut ex, &s.frame, &params);
                    let ls = score_lines(&truth, &x.lines, s.frame.beams(), sigma, &gates);
                    t.add(&ls, &Default::default(), x.segments.len(), 0.0);
                }
            }
        }
        for (v, t) in variants.iter().zip(&tallies) {
            let m = t.summary();
            println!(
                "| {} mm | {} | {:.3} | {:.3} | {:.2} | {:.2} | {:.3} | {:.2} / {:.2} | {:.2} |",
                sigma * 1e3,
                v.0,
                m.true_pos,
                m.false_pos,
                m.crb_alpha,
                m.crb_r,
                m.outliers,
                m.crb_alpha_inliers,
                m.crb_r_inliers,
                m.nees_line_median
            );
        }
    }
    Ok(())
}
