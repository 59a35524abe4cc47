//! The projections panoconv writes, and what each one means for an output camera, in one
//! place with exhaustive matches: a new linear projection is a variant here, its mapping file
//! and the CLI's `--to` value.
//!
//! [`Projection`] is a *linear* projection: K and the image size alone make its camera, so
//! [`Projection::camera`] (`projection_camera.rs`: the mappings name their projection, so its
//! constructor lives apart from the enum) is total. A real fisheye lens is not one: its camera is made from
//! its lens ([`crate::camera::FisheyeCamera`]). [`OutputProjection`] is what a `projection:`
//! calib line names, either kind.

use std::f64::consts::PI;

/// A linear projection (names as in the `projection:` calib line).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Projection {
    /// Pinhole: (a, b) = (x/z, y/z); sees only the front half-space.
    Perspective,
    /// Equirectangular: (a, b) = (longitude, latitude) in radians; longitude wraps.
    Equirect,
    /// Cylindrical: (a, b) = (azimuth in radians, y / rho); azimuth wraps.
    Cylindrical,
}

/// Every linear projection, in the order the command line lists them: the one list a new
/// projection joins (the `--to` values of every command are read from it).
pub const PROJECTIONS: [Projection; 3] = [
    Projection::Equirect,
    Projection::Cylindrical,
    Projection::Perspective,
];

impl Projection {
    /// The lowercase name written in calib `projection:` lines and exports.
    pub fn name(self) -> &'static str {
        match self {
            Projection::Perspective => "perspective",
            Projection::Equirect => "equirect",
            Projection::Cylindrical => "cylindrical",
        }
    }

    /// The vertical scale that goes with a horizontal one of `fu` for a source whose focal
    /// lengths are `src_fu` and `src_fv`: equirect pixels are square in angle; the others
    /// keep the source's aspect (Plaut et al.: f_phi/f_y = f_X/f_Y).
    pub fn fv(self, fu: f64, src_fu: f64, src_fv: f64) -> f64 {
        match self {
            Projection::Equirect => fu,
            Projection::Perspective | Projection::Cylindrical => fu * src_fv / src_fu,
        }
    }

    /// Whether the projection can show the whole 360° of azimuth.
    pub fn wraps(self) -> bool {
        match self {
            Projection::Perspective => false,
            Projection::Equirect | Projection::Cylindrical => true,
        }
    }

    /// The largest view a camera centred on its own axis can hold, (horizontal, vertical)
    /// radians, and whether each limit itself is allowed (360° wide; equirect's 180° tall).
    pub fn view_limits(self) -> ((f64, bool), (f64, bool)) {
        match self {
            Projection::Perspective => ((PI, false), (PI, false)),
            Projection::Cylindrical => ((2.0 * PI, true), (PI, false)),
            Projection::Equirect => ((2.0 * PI, true), (PI, true)),
        }
    }

    /// The half extents (a, b) in projection coordinates of a centred view of `hfov` × `vfov`
    /// radians.
    pub fn view_half_extent(self, hfov: f64, vfov: f64) -> (f64, f64) {
        match self {
            Projection::Perspective => ((hfov / 2.0).tan(), (vfov / 2.0).tan()),
            Projection::Cylindrical => (hfov / 2.0, (vfov / 2.0).tan()),
            Projection::Equirect => (hfov / 2.0, (vfov / 2.0).min(PI / 2.0)),
        }
    }

    /// The default width of a `panoconv pano` view (no `--fov`), radians.
    pub fn default_pano_hfov(self) -> f64 {
        match self {
            Projection::Perspective => 90f64.to_radians(),
            Projection::Cylindrical | Projection::Equirect => 2.0 * PI,
        }
    }

    /// The default height of a `panoconv pano` view `hfov` wide (no `--vfov`), radians.
    pub fn default_pano_vfov(self, hfov: f64) -> f64 {
        match self {
            Projection::Perspective => hfov,
            Projection::Cylindrical => 90f64.to_radians(),
            Projection::Equirect => PI,
        }
    }

    /// The default view of `panoconv fisheye` for a lens that sees `full` radians across:
    /// the lens's own, capped for the projection.
    pub fn default_fisheye_view(self, full: f64) -> (f64, f64) {
        match self {
            Projection::Perspective => {
                (full.min(120f64.to_radians()), full.min(120f64.to_radians()))
            }
            Projection::Cylindrical => (full.min(2.0 * PI), full.min(120f64.to_radians())),
            Projection::Equirect => (full.min(2.0 * PI), full.min(PI)),
        }
    }
}

impl std::fmt::Display for Projection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a `projection:` calib line names: a linear projection or a real fisheye lens.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub enum OutputProjection {
    /// K (and the size) alone describe the camera.
    Linear(Projection),
    /// A real fisheye lens, described by its own calib lines.
    Fisheye,
}

impl OutputProjection {
    /// The lowercase name written in calib `projection:` lines and exports.
    pub fn name(self) -> &'static str {
        match self {
            OutputProjection::Linear(p) => p.name(),
            OutputProjection::Fisheye => "fisheye",
        }
    }

    /// The projection a `projection:` line names; None for an unknown name.
    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "perspective" => Self::Linear(Projection::Perspective),
            "equirect" => Self::Linear(Projection::Equirect),
            "cylindrical" => Self::Linear(Projection::Cylindrical),
            "fisheye" => Self::Fisheye,
            _ => return None,
        })
    }
}

impl From<Projection> for OutputProjection {
    fn from(p: Projection) -> Self {
        Self::Linear(p)
    }
}

impl PartialEq<Projection> for OutputProjection {
    fn eq(&self, other: &Projection) -> bool {
        *self == Self::Linear(*other)
    }
}

impl std::fmt::Debug for OutputProjection {
    /// As the projection's own variant name (`Equirect`, `Fisheye`), as messages showed it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OutputProjection::Linear(p) => std::fmt::Debug::fmt(p, f),
            OutputProjection::Fisheye => f.write_str("Fisheye"),
        }
    }
}

impl std::fmt::Display for OutputProjection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_list_holds_every_projection_once() {
        for p in PROJECTIONS {
            // a new variant stops this match compiling until it is listed here and in
            // PROJECTIONS, which the assertions then check
            let listed = match p {
                Projection::Perspective | Projection::Equirect | Projection::Cylindrical => true,
            };
            assert!(listed);
        }
        for p in [
            Projection::Perspective,
            Projection::Equirect,
            Projection::Cylindrical,
        ] {
            assert_eq!(PROJECTIONS.iter().filter(|&&q| q == p).count(), 1, "{p:?}");
        }
    }
}
