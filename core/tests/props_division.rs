//! `maths::div_rem_u64` (the device layer's 64-bit division without the
//! compiler's routine) against Rust's own `/` and `%`: edge cases, then
//! random dividends and divisors of every magnitude.

use core::num::NonZeroU64;

use lms_core::maths::{div_ceil_u64, div_rem_u64, div_u64, divisor};
use proptest::prelude::*;

fn check(n: u64, d: u64) {
    let Some(nz) = NonZeroU64::new(d) else {
        // A zero divisor has no NonZeroU64; `divisor` makes it 1.
        assert_eq!(divisor(d).get(), 1);
        return;
    };
    assert_eq!(div_rem_u64(n, nz), (n / d, n % d), "{n} / {d}");
    assert_eq!(div_u64(n, nz), n / d);
    assert_eq!(div_ceil_u64(n, nz), n.div_ceil(d), "ceil {n} / {d}");
}

#[test]
fn edge_cases_match_the_native_division() {
    let values = [
        0,
        1,
        2,
        3,
        9,
        10,
        1_000_000,
        u64::from(u32::MAX) - 1,
        u64::from(u32::MAX),
        u64::from(u32::MAX) + 1,
        1 << 40,
        (1 << 63) - 1,
        1 << 63,
        (1 << 63) + 1,
        u64::MAX - 1,
        u64::MAX,
    ];
    for &n in &values {
        for &d in &values {
            check(n, d);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn random_operands_match_the_native_division(
        n in any::<u64>(),
        shift in 0u32..64,
        d in any::<u64>(),
    ) {
        // Divisors of every magnitude, not only near 2⁶⁴.
        check(n, d >> shift);
        check(n >> shift, d);
    }
}
