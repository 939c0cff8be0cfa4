//! A node colour and OctoMap's colour arithmetic (`ColorOcTreeNode::Color` and the rules of
//! `averageNodeColor`, `integrateNodeColor` and `getAverageChildColor`).
//!
//! The functions here are the whole of OctoMap 1.9.7's colour maths, kept apart from the tree
//! so the tree code only decides *which* colours meet, never how they combine.

/// An 8-bit RGB colour, as OctoMap's `ColorOcTreeNode::Color` (written to `.ot` as `r g b`).
///
/// OctoMap has no "no colour" flag: a node is white (255, 255, 255) until a colour is set, and
/// white counts as unset everywhere ([`Color::is_set`]), so a colour that really is white is
/// ignored by averages, as in OctoMap.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Color {
    /// Red.
    pub r: u8,
    /// Green.
    pub g: u8,
    /// Blue.
    pub b: u8,
}

impl Default for Color {
    /// White, the colour of every new node (OctoMap's `Color()`).
    fn default() -> Self {
        Color::WHITE
    }
}

impl Color {
    /// White (255, 255, 255): every node's colour until one is set, read as "no colour".
    pub const WHITE: Color = Color::new(255, 255, 255);

    /// A colour from its three channels.
    pub const fn new(r: u8, g: u8, b: u8) -> Self {
        Color { r, g, b }
    }

    /// Whether a colour has been set: anything but white (OctoMap's `isColorSet`).
    pub fn is_set(self) -> bool {
        self != Color::WHITE
    }

    /// The three channels as an array `[r, g, b]` (the `.ot` byte order).
    pub fn to_array(self) -> [u8; 3] {
        [self.r, self.g, self.b]
    }

    /// `averageNodeColor`'s rule: the integer mean of the node's colour and `c` per channel
    /// when the node has a colour, else `c`.
    pub fn averaged_with(self, c: Color) -> Color {
        if !self.is_set() {
            return c;
        }
        let avg = |a: u8, b: u8| ((u16::from(a) + u16::from(b)) / 2) as u8;
        Color::new(avg(self.r, c.r), avg(self.g, c.g), avg(self.b, c.b))
    }

    /// `integrateNodeColor`'s rule for a node of occupancy probability `p`: when the node has
    /// a colour, `old·p + c·(0.99 − p)` per channel in `f64`, cast to a byte as C++ does on
    /// x86-64 (truncation through a 32-bit integer, so −2.5 becomes 254); else `c`.
    pub fn integrated_with(self, c: Color, p: f64) -> Color {
        if !self.is_set() {
            return c;
        }
        let mix = |old: u8, new: u8| -> u8 {
            let v = f64::from(old) * p + f64::from(new) * (0.99 - p);
            // `as i32` saturates where C++ is undefined; both agree on every v in (-2^31, 2^31)
            (v as i32) as u8
        };
        Color::new(mix(self.r, c.r), mix(self.g, c.g), mix(self.b, c.b))
    }

    /// `getAverageChildColor`: the integer mean per channel over the children that have a
    /// colour, white when none has.
    pub fn average_of(children: impl IntoIterator<Item = Color>) -> Color {
        let (mut r, mut g, mut b, mut n) = (0u32, 0u32, 0u32, 0u32);
        for c in children.into_iter().filter(|c| c.is_set()) {
            r += u32::from(c.r);
            g += u32::from(c.g);
            b += u32::from(c.b);
            n += 1;
        }
        let mean = |sum: u32| sum.checked_div(n).map(|m| m as u8);
        match (mean(r), mean(g), mean(b)) {
            (Some(r), Some(g), Some(b)) => Color::new(r, g, b),
            _ => Color::WHITE,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Color;

    #[test]
    fn white_is_unset_and_ignored() {
        assert!(!Color::WHITE.is_set());
        assert!(Color::new(255, 255, 254).is_set());
        let avg = Color::average_of([Color::WHITE, Color::new(10, 20, 31), Color::new(0, 0, 0)]);
        assert_eq!(avg, Color::new(5, 10, 15));
        assert_eq!(Color::average_of([Color::WHITE; 8]), Color::WHITE);
    }

    #[test]
    fn average_and_integrate_rules() {
        let c = Color::new(100, 0, 255);
        assert_eq!(Color::WHITE.averaged_with(c), c);
        assert_eq!(
            Color::new(1, 3, 255).averaged_with(Color::new(2, 4, 0)),
            Color::new(1, 3, 127)
        );
        assert_eq!(Color::WHITE.integrated_with(c, 0.7), c);
        // 100·0.5 + 200·0.49 = 148
        assert_eq!(
            Color::new(100, 100, 100).integrated_with(Color::new(200, 200, 200), 0.5),
            Color::new(148, 148, 148)
        );
        // a negative mix wraps as the C++ cast does on x86-64: -2.55 -> -2 -> 254
        assert_eq!(
            Color::new(0, 0, 0).integrated_with(Color::new(255, 255, 255), 1.0),
            Color::new(254, 254, 254)
        );
    }
}
