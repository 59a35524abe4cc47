//! KITTI's cameras by number, so that a camera is never an unchecked index.

use serde::{Serialize, Serializer};

/// One of KITTI's four cameras: 0 and 1 grey, 2 and 3 colour (left and right). Its number is
/// the digit of `P2`, `image_2/`, `K2:`; panoconv converts the colour ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Cam {
    /// The left grey camera (the rect frame's reference).
    C0,
    /// The right grey camera.
    C1,
    /// The left colour camera: `image_2/`, labels and depth belong to it.
    C2,
    /// The right colour camera: `image_3/`.
    C3,
}

impl Cam {
    /// Every camera, by number.
    pub const ALL: [Cam; 4] = [Cam::C0, Cam::C1, Cam::C2, Cam::C3];

    /// The camera numbered `n`, if there is one.
    pub fn from_number(n: usize) -> Option<Cam> {
        Cam::ALL.get(n).copied()
    }

    /// The camera's number (0 to 3), also its index in per-camera arrays.
    pub fn number(self) -> usize {
        self as usize
    }
}

impl std::fmt::Display for Cam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.number())
    }
}

/// Written as its number (manifests record `"cameras": [2, 3]`).
impl Serialize for Cam {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u64(self.number() as u64)
    }
}
