//! The four keys and what each one does.
//!
//! The manual printed every key symbol as a picture, which the text lost ("pressing the  key
//! starts the parameterization mode"; AP10T A1). Only the status word (bit 0 front key, 13 "←",
//! 14 "*", 15 "↑") and 5F1Ch sub 0 name keys. Every function whose key the text lost is
//! assigned in [`KEYMAP`], one line each, so that a correction is a one-line change; the
//! reasons are D-AP-7 in `docs/decisions.md`.
//!
//! Keys act on the press (the debounced edge); there is no long press and no auto-repeat, the
//! manual defines none. The status word reports the levels ([`KeySet`]).

use super::words::StatusWord;

/// One of the four keys.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Key {
    /// The large front key (status word bit 0).
    Front,
    /// The "←" symbol key (status word bit 13).
    Left,
    /// The "*" symbol key (status word bit 14).
    Star,
    /// The "↑" symbol key (status word bit 15).
    Up,
}

impl Key {
    /// All keys, in the board's bit order (`board_plan::keys`: bit 0 front, 1 "←", 2 "*",
    /// 3 "↑").
    pub const ALL: [Key; 4] = [Key::Front, Key::Left, Key::Star, Key::Up];

    /// The key's bit in a [`KeySet`] (the board's bit order).
    pub const fn mask(self) -> u8 {
        match self {
            Key::Front => 1 << 0,
            Key::Left => 1 << 1,
            Key::Star => 1 << 2,
            Key::Up => 1 << 3,
        }
    }
}

/// A set of keys, e.g. those held down; bit `k` = [`Key::ALL`]`[k]`, as `board_plan::keys`
/// reports them.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub struct KeySet(pub u8);

impl KeySet {
    /// No key.
    pub const NONE: KeySet = KeySet(0);

    /// Whether `key` is in the set.
    pub const fn contains(self, key: Key) -> bool {
        self.0 & key.mask() != 0
    }

    /// The set with `key` added or removed.
    pub const fn with(self, key: Key, on: bool) -> KeySet {
        if on {
            KeySet(self.0 | key.mask())
        } else {
            KeySet(self.0 & !key.mask())
        }
    }

    /// Writes the key bits (0, 13, 14, 15) of a status word.
    pub fn report(self, sw: &mut StatusWord) {
        sw.front_key = self.contains(Key::Front);
        sw.left_key = self.contains(Key::Left);
        sw.star_key = self.contains(Key::Star);
        sw.up_key = self.contains(Key::Up);
    }
}

/// The acknowledgement keys as 5F1Ch sub 0 selects them.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
pub enum AckKeys {
    /// 0 (factory): the "*" key and the front key.
    #[default]
    StarAndFront,
    /// 1: only the front key.
    FrontOnly,
    /// 2: the "↑" key, the "←" key and the front key.
    ArrowsAndFront,
}

impl AckKeys {
    /// From the value of 5F1Ch sub 0; `None` outside 0..=2.
    pub const fn from_raw(v: u8) -> Option<AckKeys> {
        match v {
            0 => Some(AckKeys::StarAndFront),
            1 => Some(AckKeys::FrontOnly),
            2 => Some(AckKeys::ArrowsAndFront),
            _ => None,
        }
    }

    /// The value of 5F1Ch sub 0.
    pub const fn raw(self) -> u8 {
        self as u8
    }

    /// Whether `key` acknowledges set points.
    pub const fn acknowledges(self, key: Key) -> bool {
        matches!(
            (self, key),
            (_, Key::Front) | (AckKeys::StarAndFront, Key::Star) | (AckKeys::ArrowsAndFront, Key::Left | Key::Up)
        )
    }
}

/// Which key does what, where the manual lost the key symbol (AP10T A1, A28). The manual's own
/// assignments (front key and 5F1Ch sub 0 for acknowledgement) are in [`AckKeys`].
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub struct KeyMap {
    /// Shows node-ID and baud rate; pressed again within the key enable time (2005h sub 2) it
    /// starts the parameterization (manual 3.6.1.1). In the menu's list it leaves the menu, in
    /// the diagnosis it goes back to the list.
    pub parameterize: Key,
    /// Value input: moves the selected digit one place to the left ("decimal place selection
    /// key", 3.6.1.2).
    pub digit_select: Key,
    /// Value input: counts the selected digit up ("value input key", 3.6.1.2); in a list the
    /// next value (3.6.1.3); in the menu's list the next parameter; in the diagnosis the next
    /// error.
    pub value_input: Key,
    /// Confirms a value, a list selection, a CODE, or opens the parameter shown (3.6.1.2/3,
    /// 3.8.2).
    pub confirm: Key,
    /// Goes one level back in the menu without a change (the list to the set points, a
    /// parameter or the diagnosis to the list). Not in the manual, which names no way out.
    pub back: Key,
    /// Adopts the new node-ID while "New ID" is shown (3.4, 4.6.2).
    pub auto_id: Key,
    /// The key 2003h enables (its top-level function: acknowledgement when 5F1Ch selects it).
    pub enabled_by_2003: Key,
    /// The key 2004h enables.
    pub enabled_by_2004: Key,
}

/// The key -> function table (D-AP-7). One line per function.
pub const KEYMAP: KeyMap = KeyMap {
    parameterize: Key::Left,
    digit_select: Key::Left,
    value_input: Key::Up,
    confirm: Key::Star,
    back: Key::Front,
    auto_id: Key::Star,
    enabled_by_2003: Key::Star,
    enabled_by_2004: Key::Up,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ack_keys_as_5f1c() {
        use Key::*;
        let keys = |a: AckKeys| Key::ALL.map(|k| a.acknowledges(k));
        // Front, Left, Star, Up.
        assert_eq!(keys(AckKeys::StarAndFront), [true, false, true, false]);
        assert_eq!(keys(AckKeys::FrontOnly), [true, false, false, false]);
        assert_eq!(keys(AckKeys::ArrowsAndFront), [true, true, false, true]);
        assert_eq!(AckKeys::from_raw(3), None);
        for v in 0..=2 {
            assert_eq!(AckKeys::from_raw(v).map(AckKeys::raw), Some(v));
        }
        assert!(AckKeys::default().acknowledges(Star) && !AckKeys::default().acknowledges(Up));
    }

    #[test]
    fn key_bits_in_the_status_word() {
        let mut sw = StatusWord::default();
        KeySet::NONE.with(Key::Front, true).with(Key::Up, true).report(&mut sw);
        assert_eq!(sw.bits(), 0x8001);
        KeySet(0x0F).with(Key::Up, false).report(&mut sw);
        assert_eq!(sw.bits(), 0x6001);
        KeySet(Key::Left.mask()).report(&mut sw);
        assert_eq!(sw.bits(), 1 << 13);
    }

    #[test]
    fn the_menu_keys_are_distinct_where_they_must_be() {
        // Within the value input, selecting a digit, changing it, confirming and going back
        // need four different keys; the list needs three (next, open, back).
        let m = KEYMAP;
        let edit = [m.digit_select, m.value_input, m.confirm, m.back];
        for (i, a) in edit.iter().enumerate() {
            assert!(edit[i + 1..].iter().all(|b| b != a), "{edit:?}");
        }
        // The parameterization key is a symbol key (3.4 names the front key apart from it).
        assert_ne!(m.parameterize, Key::Front);
        assert_ne!(m.auto_id, Key::Front);
    }
}
