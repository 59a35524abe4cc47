//! The taps of a supersampled pixel from its neighbourhood, without camera maths: the source
//! positions of the pixel's centre and of its eight neighbours' (mapped anyway, for the pixels'
//! own taps and scale estimates) interpolated quadratically along each axis (the tensor product
//! of the three-point Lagrange polynomials). That is exact for a mapping of degree two per axis
//! and off by its third derivatives elsewhere, which are tiny over one output pixel except where
//! the mapping bends sharply: near a 360° source's pole, at a lens's rim, across a depth edge of
//! a depth-guided stitch. There the second differences of the nine centres are large, and the
//! pixel's taps are mapped one by one as before ([`MAX_BEND`]). Each exact tap costs an
//! unprojection, a rotation and a projection (a sine and a cosine or two each); an interpolated
//! one, twelve products.

use super::{tap_offset, Builder};
use crate::warp::table::{Wrap, MAX_SUPERSAMPLE};
use nalgebra::{Point2, Vector2};

/// Largest second difference (source pixels, along u, along v or across) of the mapped centres
/// around a pixel whose taps are interpolated. Below it the third differences that the
/// interpolation misses stay far smaller (the mapping is smooth over a few output pixels);
/// `the_interpolated_taps_are_the_exact_ones` below measures the error where it is allowed
/// (under 0.01 source pixel; 155 pixels at a pole without the limit).
pub(super) const MAX_BEND: f64 = 0.5;

/// Source pixels an interpolated tap keeps from the border of a source that does not wrap, so
/// that it lies on the same side as the exact tap (far above the interpolation's error): which
/// taps are inside, and so a pixel's coverage, is the exact mapping's.
pub(super) const BORDER_MARGIN: f64 = 0.05;

/// The source positions of a pixel's 3×3 neighbourhood of centres: rows above, here and below,
/// each columns u - 1, u, u + 1.
pub(super) type Near = [[Option<Point2<f64>>; 3]; 3];

/// The pixel's neighbourhood from the source positions of rows v - 1, v and v + 1 (columns
/// -1..=width, so pixel u is at index u + 1).
#[inline]
pub(super) fn near(rows: [&[Option<Point2<f64>>]; 3], u: usize) -> Near {
    rows.map(|row| [row[u], row[u + 1], row[u + 2]])
}

/// The positions of a neighbourhood's centres relative to its centre's (rows, then columns).
type Offsets = [[Vector2<f64>; 3]; 3];

/// The weights of the centres at offsets -1, 0 and 1 in the quadratic through them, at `t`.
#[inline(always)]
pub(super) fn lagrange(t: f64) -> [f64; 3] {
    [0.5 * t * (t - 1.0), 1.0 - t * t, 0.5 * t * (t + 1.0)]
}

impl Builder<'_> {
    /// Appends to `out` the source positions of the `nu`×`nv` taps of the pixel whose
    /// neighbourhood is `near` (row by row, each row's columns left to right, as the exact
    /// taps), interpolated; false (and `out` unchanged) where the model does not hold: a
    /// neighbour without a position, a bend above [`MAX_BEND`], or a tap at a source border.
    /// Taps sampled at pyramid level `level` are needed to a level pixel's precision: the bend
    /// and the border margin allowed are 2^level times larger in source pixels (the same
    /// error relative to a level pixel).
    pub(super) fn local_taps(
        &self,
        near: &Near,
        (nu, nv, level): (u32, u32, u32),
        out: &mut Vec<Option<Point2<f64>>>,
    ) -> bool {
        let unit = (1u32 << level) as f64;
        let Some((c, d)) = self.relative(near, unit) else {
            return false;
        };
        let start = out.len();
        let mut across = [[0.0; 3]; MAX_SUPERSAMPLE as usize];
        for (i, l) in across.iter_mut().take(nu as usize).enumerate() {
            *l = lagrange(tap_offset(i as u32, nu));
        }
        for j in 0..nv {
            let lv = lagrange(tap_offset(j, nv));
            let row: [Vector2<f64>; 3] =
                std::array::from_fn(|k| d[0][k] * lv[0] + d[1][k] * lv[1] + d[2][k] * lv[2]);
            for lu in &across[..nu as usize] {
                out.push(Some(c + (row[0] * lu[0] + row[1] * lu[1] + row[2] * lu[2])));
            }
        }
        if self.near_border(&out[start..], BORDER_MARGIN * unit) {
            out.truncate(start);
            return false;
        }
        true
    }

    /// The two taps of a pixel whose neighbourhood is `near`, side by side (`across`: 2×1, at
    /// u ∓ 1/4) or one above the other (1×2), interpolated quadratically along that axis alone
    /// from the centre and its two neighbours on it (the taps lie on the pixel's row or
    /// column: its other neighbours weigh zero in [`Builder::local_taps`], which gives the same
    /// values wherever it holds); None where a neighbour on the axis has no position, the bend
    /// along it exceeds [`MAX_BEND`] (times 2^`level`), or a tap is near a border. A pinhole
    /// source's mapping is smooth wherever its centres are: the axis's bend is the whole test
    /// (`lanes/pyramid.rs` repeats these operations in lanes). Elsewhere `local_taps`'s test
    /// of the whole neighbourhood holds too: near a 360° source's pole three smooth centres
    /// on a row can hide a turn of a level pixel between them.
    #[inline]
    pub(super) fn local_pair(
        &self,
        near: &Near,
        across: bool,
        level: u32,
    ) -> Option<[Option<Point2<f64>>; 2]> {
        let unit = (1u32 << level) as f64;
        let c = near[1][1]?;
        if self.pinhole.is_none() {
            self.relative(near, unit)?;
        }
        let [a, b] = match across {
            true => [near[1][0], near[1][2]],
            false => [near[0][1], near[2][1]],
        };
        let (a, b) = (self.short_way(a?, c), self.short_way(b?, c));
        let s = a + b;
        // (NaN fails it too)
        if !(s.x * s.x + s.y * s.y <= (MAX_BEND * unit) * (MAX_BEND * unit)) {
            return None;
        }
        let pair = [0, 1].map(|i| {
            let t = lagrange(tap_offset(i, 2));
            Some(Point2::new(
                c.x + (a.x * t[0] + b.x * t[2]),
                c.y + (a.y * t[0] + b.y * t[2]),
            ))
        });
        (!self.near_border(&pair, BORDER_MARGIN * unit)).then_some(pair)
    }

    /// The centre of a neighbourhood and its eight neighbours' positions relative to it (a
    /// 360° source's taken the short way round); None where the local model does not hold (a
    /// neighbour without a position, a bend above [`MAX_BEND`] times `unit`).
    #[inline(always)]
    fn relative(&self, near: &Near, unit: f64) -> Option<(Point2<f64>, Offsets)> {
        let c = near[1][1]?;
        let mut d = [[Vector2::zeros(); 3]; 3];
        for (dr, row) in d.iter_mut().zip(near) {
            for (e, p) in dr.iter_mut().zip(row) {
                *e = self.short_way((*p)?, c);
            }
        }
        let across = d[1][0] + d[1][2];
        let down = d[0][1] + d[2][1];
        let twist = (d[2][2] - d[2][0] - d[0][2] + d[0][0]) * 0.25;
        let bend = across
            .norm_squared()
            .max(down.norm_squared())
            .max(twist.norm_squared());
        // (NaN fails it too)
        (bend <= (MAX_BEND * unit) * (MAX_BEND * unit)).then_some((c, d))
    }

    /// Source position `p` relative to `c`, a 360° source's taken the short way round.
    #[inline(always)]
    fn short_way(&self, p: Point2<f64>, c: Point2<f64>) -> Vector2<f64> {
        let mut e = p - c;
        if self.wrap == Wrap::Horizontal {
            let w = self.source_size.width as f64;
            e.x -= w * (e.x / w).round();
        }
        e
    }

    /// Whether a tap lies within `margin` of the border of the source's valid area (columns
    /// only for a source that does not wrap).
    fn near_border(&self, taps: &[Option<Point2<f64>>], margin: f64) -> bool {
        let (w, h) = (
            self.source_size.width as f64,
            self.source_size.height as f64,
        );
        let close = |x: f64, edge: f64| (x - edge).abs() < margin;
        let columns = self.wrap == Wrap::None;
        taps.iter().flatten().any(|p| {
            close(p.y, -0.5)
                || close(p.y, h - 0.5)
                || columns && (close(p.x, -0.5) || close(p.x, w - 0.5))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Builder, Parts};
    use super::near;
    use crate::camera::{
        rotation_ypr, CameraModel, Equirect, Fisheye, ImageSize, Intrinsics, Perspective,
        Projection, RadialModel,
    };
    use crate::warp::table::Wrap;
    use nalgebra::Point2;

    /// A name, the output camera, the source camera, the turn (yaw, pitch, roll) and the wrap.
    type Case<'a> = (
        &'a str,
        &'a dyn CameraModel,
        &'a dyn CameraModel,
        [f64; 3],
        Wrap,
    );

    /// A 360° equirect panorama `width` pixels wide (half as tall).
    fn panorama(width: u32) -> Equirect {
        let w = width as f64;
        Equirect::new(
            Intrinsics::new(
                w / std::f64::consts::TAU,
                w / 2.0 / std::f64::consts::PI,
                w / 2.0 - 0.5,
                w / 4.0 - 0.5,
            ),
            ImageSize::new(width, width / 2),
        )
    }

    /// A KITTI colour camera (its size and about its intrinsics).
    fn kitti_pinhole() -> Perspective {
        Perspective::new(
            Intrinsics::new(720.0, 720.0, 620.5, 187.0),
            ImageSize::new(1242, 375),
        )
    }

    /// The largest distance (source pixels) between a pixel's interpolated taps and its exact
    /// ones, over every supersampled pixel (4×4 taps) whose taps are interpolated, and the share
    /// of the pixels whose neighbourhood lies in the source (within 2 pixels) that are.
    fn worst(
        dst: &dyn CameraModel,
        src: &dyn CameraModel,
        yaw_pitch_roll: [f64; 3],
        wrap: Wrap,
    ) -> (f64, f64) {
        let [y, p, r] = yaw_pitch_roll;
        let rot = rotation_ypr(y, p, r);
        let b = Builder::new(dst, src, &rot, wrap, 8, None);
        let size = dst.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let mut parts = Parts::default();
        let rows: Vec<Vec<Option<Point2<f64>>>> = (-1..=h as isize)
            .map(|v| {
                let mut out = Vec::new();
                b.centres(v, &mut parts, &mut out);
                out
            })
            .collect();
        let (mut worst, mut used, mut candidates) = (0.0f64, 0, 0);
        let period = src.size().width as f64;
        // (taps far outside the source take nothing, whatever their error)
        let (sw, sh) = (period, src.size().height as f64);
        let inside = |p: Point2<f64>| p.x > -2.0 && p.x < sw + 1.0 && p.y > -2.0 && p.y < sh + 1.0;
        for v in 0..h {
            for u in 0..w {
                let n = near([&rows[v], &rows[v + 1], &rows[v + 2]], u);
                if n.iter().flatten().any(|p| !p.is_some_and(inside)) {
                    continue;
                }
                candidates += 1;
                let mut got = Vec::new();
                if !b.local_taps(&n, (4, 4, 0), &mut got) {
                    continue;
                }
                used += 1;
                let mut bearings = Vec::new();
                b.tap_bearings(u as f64, v as f64, 4, 4, &mut bearings);
                let mut want = Vec::new();
                b.bearings_to_src(&mut bearings, &mut want);
                for (g, e) in got.iter().zip(&want) {
                    let (g, e) = (g.expect("a tap"), e.expect("an exact tap"));
                    if !inside(e) {
                        continue;
                    }
                    let mut dx = g.x - e.x;
                    if wrap == Wrap::Horizontal {
                        dx -= period * (dx / period).round();
                    }
                    worst = worst.max(dx.hypot(g.y - e.y));
                }
            }
        }
        (worst, used as f64 / candidates.max(1) as f64)
    }

    #[test]
    fn the_interpolated_taps_are_the_exact_ones() {
        // A tap interpolated from the nine centres lies within 0.01 source pixel of the exact
        // one wherever the bend allows it, near a 360° source's poles (an equirect output
        // tilted 40°, scale about 2), on a fisheye output's rim seen from a pinhole (scale up
        // to 8) and on a coarse perspective view of a pinhole; and most pixels use it.
        let pano = panorama(800);
        let small = Projection::Equirect.camera(
            Intrinsics::new(
                400.0 / std::f64::consts::TAU,
                200.0 / std::f64::consts::PI,
                199.5,
                99.5,
            ),
            ImageSize::new(400, 200),
        );
        let pinhole = kitti_pinhole();
        let lens = Fisheye::new(
            RadialModel::Equidistant,
            Intrinsics::new(60.0, 60.0, 100.0, 80.0),
            ImageSize::new(200, 160),
            190f64.to_radians(),
        )
        .expect("lens");
        let coarse = Perspective::new(
            Intrinsics::new(90.0, 90.0, 80.0, 30.0),
            ImageSize::new(160, 60),
        );
        let wide = Projection::Cylindrical.camera(
            Intrinsics::new(40.0, 40.0, 150.0, 60.0),
            ImageSize::new(300, 120),
        );
        let cases: [Case; 4] = [
            (
                "pano poles",
                small.as_ref(),
                &pano,
                [0.3, 0.7, 0.2],
                Wrap::Horizontal,
            ),
            (
                "fisheye of a pinhole",
                &lens,
                &pinhole,
                [0.1, 0.05, 0.0],
                Wrap::None,
            ),
            (
                "lens rim",
                wide.as_ref(),
                &lens,
                [0.2, 0.1, 0.0],
                Wrap::None,
            ),
            (
                "coarse view",
                &coarse,
                &pinhole,
                [0.2, -0.1, 0.1],
                Wrap::None,
            ),
        ];
        for (name, dst, src, ypr, wrap) in cases {
            let (err, share) = worst(dst, src, ypr, wrap);
            eprintln!(
                "{name}: worst tap {err:.5} px, {:.1} % interpolated",
                share * 100.0
            );
            assert!(
                err < 0.01,
                "{name}: an interpolated tap {err} px from the exact one"
            );
            assert!(share > 0.5, "{name}: {share}");
        }
    }

    #[test]
    fn a_pair_is_the_general_rules_two_taps_or_the_exact_ones() {
        // `local_pair` gives `local_taps`'s 2×1 and 1×2 taps wherever that holds, and where
        // only it holds (a pinhole's pixel whose neighbours off its axis are missing: the
        // footprint's edge) taps within 0.01 level pixel of the exact ones; a 360° source
        // near its poles keeps the general rule: a pinhole seen by a turned cylindrical view
        // (the training samples' case) and a panorama, at levels 0 to 3
        let pinhole = kitti_pinhole();
        let view = Projection::Cylindrical.camera(
            Intrinsics::new(150.0, 150.0, 160.0, 60.0),
            ImageSize::new(320, 120),
        );
        let pano = panorama(400);
        let cases: [Case; 2] = [
            (
                "cylindrical view",
                view.as_ref(),
                &pinhole,
                [0.2, -0.05, 0.08],
                Wrap::None,
            ),
            (
                "pano poles",
                view.as_ref(),
                &pano,
                [0.3, 1.2, 0.2],
                Wrap::Horizontal,
            ),
        ];
        for (name, dst, src, [y, p, r], wrap) in cases {
            // (only a pinhole's pairs hold where the general rule does not)
            let pinhole = src.pinhole().is_some();
            let rot = rotation_ypr(y, p, r);
            let b = Builder::new(dst, src, &rot, wrap, 8, None);
            let (w, h) = (dst.size().width as usize, dst.size().height as isize);
            let period = src.size().width as f64;
            let mut parts = Parts::default();
            let rows: Vec<Vec<Option<Point2<f64>>>> = (-1..=h)
                .map(|v| {
                    let mut out = Vec::new();
                    b.centres(v, &mut parts, &mut out);
                    out
                })
                .collect();
            let (mut same, mut alone, mut refused, mut worst) = (0, 0, 0, 0.0f64);
            for v in 0..h as usize {
                for u in 0..w {
                    let n = near([&rows[v], &rows[v + 1], &rows[v + 2]], u);
                    for (level, across) in (0..4).flat_map(|k| [(k, true), (k, false)]) {
                        let mut general = Vec::new();
                        let (nu, nv) = if across { (2, 1) } else { (1, 2) };
                        let ok = b.local_taps(&n, (nu, nv, level), &mut general);
                        let Some(pair) = b.local_pair(&n, across, level) else {
                            assert!(!ok, "{name} ({u}, {v}) level {level}: refused alone");
                            refused += 1;
                            continue;
                        };
                        if ok {
                            assert_eq!(&pair[..], &general[..], "{name} ({u}, {v})");
                            same += 1;
                            continue;
                        }
                        let mut bearings = Vec::new();
                        b.tap_bearings(u as f64, v as f64, nu, nv, &mut bearings);
                        let mut exact = Vec::new();
                        b.bearings_to_src(&mut bearings, &mut exact);
                        for (g, e) in pair.iter().zip(&exact) {
                            let (g, e) = (g.expect("a tap"), e.expect("an exact tap"));
                            let mut dx = g.x - e.x;
                            if wrap == Wrap::Horizontal {
                                dx -= period * (dx / period).round();
                            }
                            worst = worst.max(dx.hypot(g.y - e.y) / (1u32 << level) as f64);
                        }
                        alone += 1;
                    }
                }
            }
            eprintln!("{name}: {same} as local_taps, {alone} alone (worst {worst:.5} level px), {refused} refused");
            // (each outcome met: the comparison covers it)
            assert!(same > 1000 && refused > 100, "{name}: {same}, {refused}");
            assert_eq!(alone > 10, pinhole, "{name}: {alone} alone");
            assert!(
                worst < 0.01,
                "{name}: a tap {worst} level pixels from the exact one"
            );
        }
    }
}
