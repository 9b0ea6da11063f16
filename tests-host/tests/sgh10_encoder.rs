//! SGH10 position pipeline: property tests over the whole value ranges, on the device itself
//! (scaling, calibration round trip, direction change, work areas). The sensor reads the wire
//! extension in µm; 6005h.01 = 100000 nm makes a step 0.1 mm.

use od_core::devices::sgh10::{Sgh10, Variant};
use od_core::{Bitrate, Instant, Node};
use proptest::prelude::*;
use tests_host::encoder::{direct_write, value};

// Property tests of the position pipeline over the whole value ranges, on the device itself.

const MAX_UM: u32 = 10239 * 100 + 99;

fn device_at(um: u32) -> (Node<Sgh10>, Instant) {
    let mut node = Node::new(Sgh10::new(Variant::Sgh10), 1, Bitrate::K500);
    let now = Instant::from_millis(1);
    let (d, core) = node.split();
    od_core::encoder::Encoder::on_sample(d, core, Ok(um), now);
    (node, now)
}

fn sample(node: &mut Node<Sgh10>, um: u32, now: Instant) -> i64 {
    let (d, core) = node.split();
    od_core::encoder::Encoder::on_sample(d, core, Ok(um), now);
    value(node.core(), 0x6020, 1)
}

proptest! {
    #[test]
    fn scaling_is_the_reading_in_whole_steps(um in 0..=MAX_UM) {
        let (node, _) = device_at(um);
        let p = value(node.core(), 0x6020, 1);
        prop_assert!(p * 100 <= um as i64 && (um as i64) < (p + 1) * 100);
        prop_assert_eq!(value(node.core(), 0x6503, 0), 0);
    }

    #[test]
    fn calibration_round_trip(um in 0..=MAX_UM, later in 0..=MAX_UM, c in -10239i32..=10239, descending: bool) {
        let (mut node, now) = device_at(um);
        if descending {
            direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        }
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
        let moved = (later / 100) as i64 - (um / 100) as i64;
        let p = sample(&mut node, later, now);
        prop_assert_eq!(p, c as i64 + if descending { -moved } else { moved });
        // The offset is the encoder value minus the position, and the position stays
        // within the manual's transferable range.
        let m = if descending { -((later / 100) as i64) } else { (later / 100) as i64 };
        prop_assert_eq!(value(node.core(), 0x6509, 0), m - p);
        prop_assert!((-20478..=30717).contains(&p));
    }

    #[test]
    fn direction_change_mirrors_and_twice_is_identity(um in 0..=MAX_UM, c in -10239i32..=10239) {
        let (mut node, now) = device_at(um);
        direct_write(&mut node, 0x6010, 1, c as u32, now).unwrap();
        direct_write(&mut node, 0x6000, 0, 0x000C, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), -(c as i64));
        prop_assert_eq!(value(node.core(), 0x6500, 0), 0x000C);
        direct_write(&mut node, 0x6000, 0, 0x0004, now).unwrap();
        prop_assert_eq!(value(node.core(), 0x6020, 1), c as i64);
        prop_assert_eq!(sample(&mut node, um, now), c as i64);
    }

    #[test]
    fn work_area_state_matches_the_limits(um in 0..=MAX_UM, low in -20478i32..=30717, high in -20478i32..=30717) {
        let (mut node, now) = device_at(um);
        direct_write(&mut node, 0x6401, 1, low as u32, now).unwrap();
        direct_write(&mut node, 0x6402, 1, high as u32, now).unwrap();
        let p = (um / 100) as i32;
        let below = p < low;
        let above = p > high;
        let expected = (below || above) as i64 | (above as i64) << 1 | (below as i64) << 2;
        prop_assert_eq!(value(node.core(), 0x6400, 1), expected);
        prop_assert_eq!(value(node.core(), 0x6503, 0) & 0x1000 != 0, below || above);
        prop_assert_eq!(node.core().emcy.is_active(0xFF15), below || above);
    }
}
