//! Integer arithmetic the Cortex-M3 has no instruction for, without the library routines.
//!
//! The M3 divides 32-bit numbers in hardware; a 64-bit division or remainder is a library
//! routine of about 1 KiB of flash and hundreds of cycles. Every 64-bit remainder the core
//! needs (positions on a circle of counts, phases of periodic patterns) has a 32-bit modulus,
//! so [`rem_u64`] does it by shifts and subtractions, and the callers take a 32-bit fast path
//! first where their operands allow.

/// `x mod m` for a 64-bit `x` and a 32-bit `m > 0` (0 for `m == 0`): binary long division,
/// one shift, compare and subtract per bit, no division.
pub const fn rem_u64(x: u64, m: u32) -> u32 {
    if m == 0 {
        return 0;
    }
    if x <= u32::MAX as u64 {
        return x as u32 % m;
    }
    let m = m as u64;
    let mut r = 0u64;
    let mut bit = 64;
    while bit > 0 {
        bit -= 1;
        // r < m < 2^32: the shifted remainder fits 33 bits.
        r = (r << 1) | ((x >> bit) & 1);
        if r >= m {
            r -= m;
        }
    }
    r as u32
}

/// The Euclidean remainder of `x` by `m > 0`, in `0 .. m` (`i64::rem_euclid` for a 32-bit
/// modulus; 0 for `m == 0`).
pub const fn rem_euclid(x: i64, m: u32) -> u32 {
    let r = rem_u64(x.unsigned_abs(), m);
    if x < 0 && r != 0 {
        m - r
    } else {
        r
    }
}

/// `a × b`, saturating at `u64::MAX`: two 32 × 32-bit multiplications (a 64 × 64-bit one
/// that checks its overflow is much larger on the Cortex-M3).
pub const fn mul_sat(a: u64, b: u32) -> u64 {
    let lo = (a as u32 as u64) * b as u64;
    let hi = ((a >> 32) as u32 as u64) * b as u64;
    if hi > u32::MAX as u64 {
        return u64::MAX;
    }
    lo.saturating_add(hi << 32)
}

/// `n / d` for unsigned 64-bit numbers (`u64::MAX` for `d == 0`): the M3's 32-bit division
/// when both fit 32 bits, else binary long division from the numerator's top bit, so the
/// library's 64-bit division (about 1 KiB on the Cortex-M3) is not linked.
pub const fn div_u64(n: u64, d: u64) -> u64 {
    if d == 0 {
        return u64::MAX;
    }
    if n < d {
        return 0;
    }
    if n <= u32::MAX as u64 {
        // d <= n: both fit.
        return (n as u32 / d as u32) as u64;
    }
    if d > u64::MAX >> 1 {
        // d <= n < 2d.
        return 1;
    }
    // The numerator's bits move from `n` into the remainder, the quotient's bits in behind
    // them: shifts by one only, which the M3 does in two instructions (a shift by a variable
    // count of a 64-bit number is a library call).
    let mut n = n;
    let mut r = 0u64;
    let mut i = 0;
    while i < 64 {
        // r < d < 2^63: the shifted remainder fits.
        r = (r << 1) | (n >> 63);
        n <<= 1;
        if r >= d {
            r -= d;
            n |= 1;
        }
        i += 1;
    }
    n
}

/// `n / d` for unsigned 128-bit numbers with `d` below 2^127 (`u128::MAX` for `d == 0`):
/// binary long division from the numerator's top bit. The library's 128-bit division is over
/// 1 KiB on the Cortex-M3; this is a few dozen bytes, and the callers (a speed once per
/// integration time) need no speed.
pub const fn div_u128(n: u128, d: u128) -> u128 {
    if d == 0 {
        return u128::MAX;
    }
    let mut q = 0u128;
    let mut r = 0u128;
    let mut bit = 128 - n.leading_zeros();
    while bit > 0 {
        bit -= 1;
        // r < d < 2^127: the shifted remainder fits.
        r = (r << 1) | ((n >> bit) & 1);
        if r >= d {
            r -= d;
            q |= 1 << bit;
        }
    }
    q
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remainders_equal_the_64_bit_ones() {
        let mut x = 0x0123_4567_89AB_CDEFu64;
        for _ in 0..50_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            for v in [x, x >> 20, x >> 40, x >> 60] {
                for m in [1u32, 3, 16_384, 262_144, 67_108_864, (x >> 33) as u32 | 1, u32::MAX] {
                    assert_eq!(rem_u64(v, m) as u64, v % m as u64, "{v} % {m}");
                    let s = v as i64;
                    assert_eq!(rem_euclid(s, m) as i64, s.rem_euclid(m as i64), "{s} rem {m}");
                    assert_eq!(rem_euclid(-(v as i64 >> 1), m) as i64, (-(v as i64 >> 1)).rem_euclid(m as i64));
                }
            }
        }
        assert_eq!(rem_euclid(i64::MIN, 7) as i64, i64::MIN.rem_euclid(7));
        assert_eq!(rem_u64(5, 0), 0);
    }

    #[test]
    fn quotients_equal_the_64_bit_ones() {
        let mut x = 0x0123_4567_89AB_CDEFu64;
        for _ in 0..50_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            for n in [x, x >> 20, x >> 33, x >> 50, u64::MAX] {
                for d in [1u64, 3, 1000, (x >> 40) | 1, (x >> 20) | 1, (x >> 1) | 1, x | 1 << 63, u64::MAX] {
                    assert_eq!(div_u64(n, d), n / d, "{n} / {d}");
                }
            }
        }
        assert_eq!(div_u64(7, 0), u64::MAX);
        for a in [0, 1, u32::MAX as u64, u32::MAX as u64 + 1, 1 << 40, u64::MAX / 3, u64::MAX] {
            for b in [0, 1, 3, 100, u32::MAX] {
                assert_eq!(mul_sat(a, b), a.saturating_mul(b as u64), "{a} × {b}");
            }
        }
    }

    #[test]
    fn quotients_equal_the_128_bit_ones() {
        let mut x = 0x0123_4567_89AB_CDEFu128;
        for _ in 0..50_000 {
            x = x.wrapping_mul(0x2360_ED05_1FC6_5DA4_4385_DF64_9FCC_F645).wrapping_add(0x5851_F42D_4C95_7F2D);
            for n in [x, x >> 30, x >> 70, x >> 100] {
                for d in [1u128, 3, 1000, (x >> 64) | 1, (x >> 90) | 1, (x >> 1) | 1] {
                    assert_eq!(div_u128(n, d), n / d, "{n} / {d}");
                }
            }
        }
        assert_eq!(div_u128(u128::MAX, (1 << 127) - 1), 2);
        assert_eq!(div_u128(7, 0), u128::MAX);
    }
}
