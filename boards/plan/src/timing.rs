//! bxCAN bit timing: prescaler and segment lengths for a bit rate, from the CAN clock.
//!
//! A bit is `1 + seg1 + seg2` time quanta of `prescaler` CAN clock cycles each; the sample
//! point lies after `1 + seg1` quanta. The bxCAN takes `seg1` 1..=16, `seg2` 1..=8, `sjw`
//! 1..=4 and a prescaler 1..=1024 (RM0008 §24.7.7). CiA 301 / CiA 102 recommend a sample point
//! at 87.5 % for every CANopen rate; [`bit_timing`] picks the exact division closest to it,
//! and among equally close ones the one with the most quanta (finer resynchronisation).

use od_core::Bitrate;

/// The CAN clock of the boards: APB1 at 36 MHz (8 MHz HSE, PLL ×9 = 72 MHz SYSCLK, APB1 / 2).
pub const APB1_HZ: u32 = 36_000_000;

/// Target sample point in per mille of the bit time.
pub const SAMPLE_POINT_PERMILLE: u32 = 875;

/// One bit timing for the bxCAN.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct BitTiming {
    /// Clock cycles per time quantum (1..=1024).
    pub prescaler: u16,
    /// Time segment 1 in quanta, propagation and phase 1 (1..=16).
    pub seg1: u8,
    /// Time segment 2 in quanta, phase 2 (1..=8).
    pub seg2: u8,
    /// Resynchronisation jump width in quanta (1..=4, at most `seg2`).
    pub sjw: u8,
}

impl BitTiming {
    /// Time quanta per bit.
    pub const fn quanta(&self) -> u32 {
        1 + self.seg1 as u32 + self.seg2 as u32
    }

    /// The bit rate this timing gives at `clock_hz`.
    pub const fn bitrate(&self, clock_hz: u32) -> u32 {
        clock_hz / (self.prescaler as u32 * self.quanta())
    }

    /// The sample point in per mille of the bit time.
    pub const fn sample_point_permille(&self) -> u32 {
        (1 + self.seg1 as u32) * 1000 / self.quanta()
    }

    /// The CAN_BTR register value (without the loop-back and silent bits).
    pub const fn btr(&self) -> u32 {
        (self.prescaler as u32 - 1)
            | ((self.seg1 as u32 - 1) << 16)
            | ((self.seg2 as u32 - 1) << 20)
            | ((self.sjw as u32 - 1) << 24)
    }
}

/// Why no timing fits.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct NoTiming;

/// The bit timing for `bits_per_second` at a CAN clock of `clock_hz`: an exact division
/// (no bit-rate error), 8..=25 quanta per bit, the sample point closest to 87.5 %, SJW 1 quantum
/// (the bxCAN's reset value; CiA 102 allows it at every rate). `Err` when no exact division
/// exists.
pub const fn bit_timing(clock_hz: u32, bits_per_second: u32) -> Result<BitTiming, NoTiming> {
    if bits_per_second == 0 {
        return Err(NoTiming);
    }
    let mut best: Option<(BitTiming, u32)> = None;
    let mut quanta = 25u32;
    while quanta >= 8 {
        let per_bit = bits_per_second as u64 * quanta as u64;
        if (clock_hz as u64).is_multiple_of(per_bit) {
            let prescaler = clock_hz as u64 / per_bit;
            if prescaler >= 1 && prescaler <= 1024 {
                let mut seg2 = 1u32;
                while seg2 <= 8 && seg2 < quanta - 1 {
                    let seg1 = quanta - 1 - seg2;
                    if seg1 >= 1 && seg1 <= 16 {
                        let t = BitTiming { prescaler: prescaler as u16, seg1: seg1 as u8, seg2: seg2 as u8, sjw: 1 };
                        let sp = t.sample_point_permille();
                        let dist = sp.abs_diff(SAMPLE_POINT_PERMILLE);
                        // Strictly better only: the first found (most quanta) wins a tie.
                        let better = match best {
                            None => true,
                            Some((_, d)) => dist < d,
                        };
                        if better {
                            best = Some((t, dist));
                        }
                    }
                    seg2 += 1;
                }
            }
        }
        quanta -= 1;
    }
    match best {
        Some((t, _)) => Ok(t),
        None => Err(NoTiming),
    }
}

/// The boards' timing for a CANopen bit rate (APB1 at 36 MHz). Every [`Bitrate`] has one.
pub const fn for_bitrate(rate: Bitrate) -> BitTiming {
    match bit_timing(APB1_HZ, rate.bits_per_second()) {
        Ok(t) => t,
        Err(_) => panic!("no bxCAN timing for a CANopen rate at 36 MHz"),
    }
}

/// Every rate's timing, evaluated at compile time: a rate without an exact timing would fail
/// the build, not the bus.
pub const TABLE: [BitTiming; 9] = {
    let mut t = [BitTiming { prescaler: 1, seg1: 1, seg2: 1, sjw: 1 }; 9];
    let mut i = 0;
    while i < 9 {
        t[i] = for_bitrate(Bitrate::ALL[i]);
        i += 1;
    }
    t
};

/// The boards' timing for `rate`, from [`TABLE`] (no computation at run time).
pub const fn of(rate: Bitrate) -> BitTiming {
    TABLE[rate as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(t: &BitTiming, rate: Bitrate) {
        assert_eq!(t.bitrate(APB1_HZ), rate.bits_per_second(), "{rate:?} exact");
        assert_eq!(APB1_HZ % (t.prescaler as u32 * t.quanta()), 0, "{rate:?} no rounding");
        assert!((1..=1024).contains(&t.prescaler), "{rate:?} prescaler");
        assert!((1..=16).contains(&t.seg1) && (1..=8).contains(&t.seg2), "{rate:?} segments");
        assert!(t.sjw >= 1 && t.sjw <= t.seg2 && t.sjw <= 4, "{rate:?} sjw");
        assert!((8..=25).contains(&t.quanta()), "{rate:?} quanta");
        let sp = t.sample_point_permille();
        assert!((850..=900).contains(&sp), "{rate:?} sample point {sp}");
    }

    #[test]
    fn every_canopen_rate_is_exact_near_87_5_percent() {
        for (i, rate) in Bitrate::ALL.iter().enumerate() {
            let t = bit_timing(APB1_HZ, rate.bits_per_second()).unwrap();
            check(&t, *rate);
            assert_eq!(TABLE[i], t);
            assert_eq!(for_bitrate(*rate), t);
            assert_eq!(of(*rate), t, "{rate:?}: the table is indexed by the rate");
        }
    }

    #[test]
    fn known_register_values() {
        // 1 Mbit/s: 2 × 18 quanta, sample point 16/18 = 88.9 %.
        let t = for_bitrate(Bitrate::K1000);
        assert_eq!((t.prescaler, t.seg1, t.seg2, t.sjw), (2, 15, 2, 1));
        assert_eq!(t.btr(), 0x001E_0001);
        // 800 kbit/s: 3 × 15 quanta, 13/15 = 86.7 %.
        let t = for_bitrate(Bitrate::K800);
        assert_eq!((t.prescaler, t.seg1, t.seg2), (3, 12, 2));
        // 500 kbit/s: 9 × 8 quanta, exactly 87.5 % (18 quanta would give 88.9 %).
        let t = for_bitrate(Bitrate::K500);
        assert_eq!((t.prescaler, t.seg1, t.seg2), (9, 6, 1));
        assert_eq!(t.btr(), 0x0005_0008);
        // 125 kbit/s: 18 × 16 quanta, exactly 87.5 %.
        let t = for_bitrate(Bitrate::K125);
        assert_eq!((t.prescaler, t.seg1, t.seg2), (18, 13, 2));
        assert_eq!(t.sample_point_permille(), 875);
        // 20 kbit/s: 225 × 8 quanta.
        let t = for_bitrate(Bitrate::K20);
        assert_eq!((t.prescaler, t.seg1, t.seg2), (225, 6, 1));
    }

    #[test]
    fn exact_87_5_is_taken_where_the_clock_allows() {
        // 36 MHz / rate is a multiple of 8 for every rate up to 500 kbit/s.
        for rate in &Bitrate::ALL[..7] {
            assert_eq!(for_bitrate(*rate).sample_point_permille(), 875, "{rate:?}");
        }
        // 1 Mbit/s (36 = 2 × 18) and 800 kbit/s (45 = 3 × 15) cannot: 88.9 % and 86.7 %.
        assert_eq!(for_bitrate(Bitrate::K1000).sample_point_permille(), 888);
        assert_eq!(for_bitrate(Bitrate::K800).sample_point_permille(), 866);
    }

    #[test]
    fn impossible_rates_are_refused() {
        assert_eq!(bit_timing(APB1_HZ, 0), Err(NoTiming));
        // 36 MHz / 7 kbit/s has no exact division into 8..=25 quanta.
        assert_eq!(bit_timing(APB1_HZ, 7_000), Err(NoTiming));
        // Above the controller's reach: 36 MHz / 8 quanta = 4.5 Mbit/s is the fastest.
        assert_eq!(bit_timing(APB1_HZ, 5_000_000), Err(NoTiming));
        assert!(bit_timing(APB1_HZ, 4_500_000).is_ok());
        // Too slow for a 1024 prescaler.
        assert_eq!(bit_timing(APB1_HZ, 1_000), Err(NoTiming));
    }

    #[test]
    fn other_clocks() {
        // An 8 MHz clock: 1 Mbit/s = 1 × 8 quanta at exactly 87.5 %.
        let t = bit_timing(8_000_000, 1_000_000).unwrap();
        assert_eq!((t.prescaler, t.quanta()), (1, 8));
        assert_eq!(t.sample_point_permille(), 875);
        assert!(bit_timing(8_000_000, 800_000).is_ok()); // 1 × 10 quanta
        assert_eq!(bit_timing(8_000_000, 800_000).unwrap().quanta(), 10);
    }
}
