//! Parameter sets the evaluation compares the defaults with: the defaults
//! with groups of their decisions turned off, each set on top of the one
//! before, from [`Params::V3_0`] (the merges refitting every beam between
//! the lines) down to ALGORITHM.md v2 ([`Params::V2`]). Each row of such a
//! table shows what the group it turns off adds (docs/DESIGN.md).

use lms_core::Params;

/// [`Params::V3_0`] (the defaults with the merges refitting every beam
/// between the lines, `merge_own_beams = false`) with pairs of lines on a
/// curve kept (`arc_pairs = false`).
pub const ARC_PAIRS_KEPT: Params = Params::V3_0.with_arc_pairs(false);

/// [`ARC_PAIRS_KEPT`] with no anchor gate on the merges and no per-turn
/// offsets in the fits' χ² (`merge_anchor_gate = inf`,
/// `turn_offsets = false`).
pub const NO_ANCHOR_NO_OFFSETS: Params = ARC_PAIRS_KEPT
    .with_merge_anchor_gate(f32::INFINITY)
    .with_turn_offsets(false);

/// [`NO_ANCHOR_NO_OFFSETS`] with windows of consecutive beams in every
/// mode and no work bound on split before reject
/// (`same_turn_windows = false`, `split_budget = 0`).
pub const CONSECUTIVE_WINDOWS: Params = NO_ANCHOR_NO_OFFSETS
    .with_same_turn_windows(false)
    .with_split_budget(0);

/// [`CONSECUTIVE_WINDOWS`] with every line of an arc kept
/// (`arc_chain = 0`). With the footprint weights and the bridge merge off
/// too, this is [`Params::V2`].
pub const ARC_CHAINS_KEPT: Params = CONSECUTIVE_WINDOWS.with_arc_chain(0);

/// Name of [`ARC_PAIRS_KEPT`] in the tables.
pub const ARC_PAIRS_KEPT_NAME: &str = "v3.0, arc_pairs=false";
/// Name of [`NO_ANCHOR_NO_OFFSETS`] in the tables.
pub const NO_ANCHOR_NO_OFFSETS_NAME: &str =
    "v3.0, arc_pairs=false, merge_anchor_gate=inf, turn_offsets=false";
/// Name of [`CONSECUTIVE_WINDOWS`] in the tables.
pub const CONSECUTIVE_WINDOWS_NAME: &str = "v3.0, arc_pairs=false, merge_anchor_gate=inf, \
     turn_offsets=false, same_turn_windows=false, split_budget=0";
/// Name of [`ARC_CHAINS_KEPT`] in the tables.
pub const ARC_CHAINS_KEPT_NAME: &str = "v3.0, arc_pairs=false, merge_anchor_gate=inf, \
     turn_offsets=false, same_turn_windows=false, split_budget=0, arc_chain=0";

#[cfg(test)]
mod tests {
    use super::*;

    /// The chain ends at ALGORITHM.md v2 as the core defines it.
    #[test]
    fn chain_ends_at_v2() {
        let v2 = ARC_CHAINS_KEPT.with_footprint(0.0).with_bridge_merge(false);
        assert_eq!(v2, Params::V2);
    }
}
