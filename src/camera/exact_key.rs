//! [`ExactKey`]: the exact bits of a camera's geometry, for a cache that reuses what one camera
//! built for another only where the two are the same bit for bit (a rig run's kept stitches).

use super::{ImageSize, Intrinsics};

/// Values fed one by one, each as whole 64-bit words: a float by its bit pattern
/// ([`f64::to_bits`], so that one ULP, or 0.0 against -0.0, is another key), a count as
/// itself, a name by its length and bytes. Two keys are equal exactly where the same values
/// were fed in the same order: the words are kept, not hashed, so no two geometries share one.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct ExactKey(Vec<u64>);

impl ExactKey {
    /// An empty key.
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds one float's bit pattern.
    pub fn float(&mut self, v: f64) {
        self.0.push(v.to_bits());
    }

    /// Feeds each float's bit pattern, after their count.
    pub fn floats(&mut self, values: &[f64]) {
        self.count(values.len());
        self.0.extend(values.iter().map(|v| v.to_bits()));
    }

    /// Feeds a count (or any whole number).
    pub fn count(&mut self, n: usize) {
        self.0.push(n as u64);
    }

    /// Feeds a name: its length, then its bytes eight to a word.
    pub fn name(&mut self, text: &str) {
        self.count(text.len());
        for chunk in text.as_bytes().chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.0.push(u64::from_le_bytes(word));
        }
    }

    /// Feeds intrinsics and an image size, every field.
    pub fn intrinsics(&mut self, k: &Intrinsics, size: ImageSize) {
        let Intrinsics { fu, fv, cu, cv } = *k;
        self.floats(&[fu, fv, cu, cv]);
        let ImageSize { width, height } = size;
        self.count(width as usize);
        self.count(height as usize);
    }

    /// Feeds a matrix's entries (column-major, as nalgebra stores them).
    pub fn matrix(&mut self, m: &nalgebra::Matrix3<f64>) {
        self.floats(m.as_slice());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_ulp_a_sign_or_a_split_name_is_another_key() {
        let key = |f: &dyn Fn(&mut ExactKey)| {
            let mut k = ExactKey::new();
            f(&mut k);
            k
        };
        let up = f64::from_bits(1.5f64.to_bits() + 1);
        assert_ne!(key(&|k| k.float(1.5)), key(&|k| k.float(up)));
        assert_ne!(key(&|k| k.float(0.0)), key(&|k| k.float(-0.0)));
        assert_eq!(key(&|k| k.float(1.5)), key(&|k| k.float(1.5)));
        // the lengths keep the boundaries: "ab" + "c" is not "a" + "bc"
        assert_ne!(
            key(&|k| {
                k.name("ab");
                k.name("c")
            }),
            key(&|k| {
                k.name("a");
                k.name("bc")
            })
        );
        assert_ne!(key(&|k| k.floats(&[1.0])), key(&|k| k.floats(&[1.0, 1.0])));
    }
}
