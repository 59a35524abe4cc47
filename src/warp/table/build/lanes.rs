//! The plain build (one tap a pixel, see `plain`) of a separable output from a pinhole source,
//! a group of [`LANES`] pixels at a time: each row's bearings come coordinate by coordinate
//! ([`Separable::bearing_lanes`]), then each group is turned into the source, projected
//! ([`pinhole_lanes`]) and made into its round, lane by lane, with the very operations of the
//! per-pixel path (the rotation's products and sums in nalgebra's order, [`Builder::block`],
//! [`quantize_block`](super::quantize_block)): the same table, in loops without branches that
//! the compiler vectorises (with AVX2 where the processor has it). A turned equirect or
//! cylindrical view drawn per training sample spends most of its table here.

use super::Builder;
use crate::camera::{pinhole_lanes, Intrinsics, Separable, Share};
use crate::warp::kernel::{Round, LANES, WEIGHT_ONE};
use crate::warp::table::{column_inside, row_inside, Cover, RemapTable};
use nalgebra::Point2;

mod pyramid;

/// One coordinate of a group's pixels, a lane each.
type Lanes = [f64; LANES];

/// A row's bearing coordinates (x, y, z) of the columns the footprint keeps.
#[derive(Default)]
struct Bearings([Vec<f64>; 3]);

impl Builder<'_> {
    /// [`Builder::plain_table`] of a separable output (`sep`) from a pinhole source of
    /// intrinsics `k`.
    pub(super) fn lanes_table(&self, sep: &dyn Separable, k: &Intrinsics) -> RemapTable {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.lanes_table_avx2(sep, k) };
        }
        self.lanes_table_any(sep, k)
    }

    /// [`Builder::lanes_table`] compiled for AVX2 (four lanes of f64 an instruction; the same
    /// IEEE operations, so the same bits).
    ///
    /// # Safety
    ///
    /// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`): the function is
    /// compiled with its instructions, which fault on a processor without them. It reads and
    /// writes only through safe slices.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn lanes_table_avx2(&self, sep: &dyn Separable, k: &Intrinsics) -> RemapTable {
        self.lanes_table_any(sep, k)
    }

    #[inline(always)]
    fn lanes_table_any(&self, sep: &dyn Separable, k: &Intrinsics) -> RemapTable {
        let size = self.dst.size();
        let (w, h) = (size.width as usize, size.height as usize);
        let groups = w.div_ceil(LANES);
        let mut t = self.one_round_a_group();
        let mut bearings = Bearings::default();
        for v in 0..h {
            let (lo, hi) = self.seen.map_or((0, w as isize - 1), |seen| {
                seen.columns(v as isize, 0, w as isize - 1)
            });
            let reach = if lo > hi {
                // (the row is blank: every pixel the all-zero block at offset 0)
                t.rounds.resize(t.rounds.len() + groups, Round::default());
                0
            } else {
                let (lo, hi) = (lo as usize, hi as usize);
                // centre_columns holds columns -1..=w
                let columns = &self.centre_columns[lo + 1..=hi + 1];
                for c in &mut bearings.0 {
                    c.resize(columns.len(), 0.0);
                }
                let [x, y, z] = &mut bearings.0;
                sep.bearing_lanes(columns, sep.row(v as f64), [x, y, z]);
                let cover = &mut t.cover[v * w..(v + 1) * w];
                self.lanes_row(k, &bearings, lo..=hi, &mut t.rounds, cover)
            };
            t.row_reach.push(reach);
            t.row_starts.push(t.rounds.len() as u32);
        }
        t
    }

    /// Appends a row's rounds from the bearings of its columns `kept` (the others take
    /// nothing) and marks the pixels they cover; gives the row's largest block offset.
    #[inline(always)]
    fn lanes_row(
        &self,
        k: &Intrinsics,
        bearings: &Bearings,
        kept: std::ops::RangeInclusive<usize>,
        rounds: &mut Vec<Round>,
        cover: &mut [Cover],
    ) -> u32 {
        let w = cover.len();
        let (lo, hi) = (*kept.start(), *kept.end());
        let mut reach = 0;
        for (g, cover) in cover.chunks_mut(LANES).enumerate() {
            let first = g * LANES;
            if first + LANES <= lo || first > hi {
                // (most groups of a wide view: outside the footprint)
                rounds.push(Round::default());
                continue;
            }
            let mut d = [[f64::NAN; LANES]; 3];
            if first >= lo && first + LANES <= hi + 1 {
                for (d, b) in d.iter_mut().zip(&bearings.0) {
                    d.copy_from_slice(&b[first - lo..first - lo + LANES]);
                }
            } else {
                for (lane, u) in (first..first + LANES).enumerate() {
                    if (lo..=hi).contains(&u) {
                        for (d, b) in d.iter_mut().zip(&bearings.0) {
                            d[lane] = b[u - lo];
                        }
                    }
                }
            }
            let (round, inside, far) = self.group(k, d);
            reach = reach.max(far);
            for (c, &inside) in cover.iter_mut().zip(&inside) {
                if inside {
                    *c = Cover::Full;
                }
            }
            rounds.push(tail(round, w - first));
        }
        reach
    }

    /// The round of a group's bearings `d` (x, y, z lanes in the output's axes, NaN x for a
    /// pixel without one), which lanes have a block inside the source, and the largest block
    /// offset: each lane what [`Builder::block`] and `quantize_block` give its centre, stage
    /// by stage over the lanes.
    #[inline(always)]
    fn group(&self, k: &Intrinsics, d: [Lanes; 3]) -> (Round, [bool; LANES], u32) {
        let [px, py] = pinhole_lanes(k, self.turn(d));
        let size = self.source_size;
        let (sw, sh) = (size.width as f64, size.height as f64);
        let (x_last, y_last) = (
            (size.width - 2) as i32,
            size.height.saturating_sub(2) as i32,
        );
        let tall = size.height > 1;
        let mut inside = [false; LANES];
        let mut offset = [0u32; LANES];
        let mut w = [[0i32; LANES]; 4];
        // one loop of scalar operations and selects (no inner loop): it vectorises
        for l in 0..LANES {
            let (x, y) = (px[l], py[l]);
            // `block`'s tests (NaN, a pixel without a centre, fails them)
            let ok = column_inside(x, sw) && row_inside(y, sh);
            // outside lanes computed on (0, 0), then dropped: no NaN reaches a conversion
            let (x, y) = if ok { (x, y) } else { (0.0, 0.0) };
            let y = clamp(y, sh - 1.0);
            // SAFETY: 0 <= y < 2^31 (clamped to the source); truncation is floor here
            let y0 = unsafe { y.to_int_unchecked::<i32>() }.min(y_last);
            let fy = if tall { y - y0 as f64 } else { 0.0 };
            let x = clamp(x, sw - 1.0);
            // SAFETY: as y
            let x0 = unsafe { x.to_int_unchecked::<i32>() }.min(x_last);
            let fx = x - x0 as f64;
            let q = quantize([
                (1.0 - fx) * (1.0 - fy),
                (1.0 - fx) * fy,
                fx * (1.0 - fy),
                fx * fy,
            ]);
            inside[l] = ok;
            // (wrapping operations that cannot wrap, the offset being below the source's pixel
            // count: no overflow checks, which would keep the loop from vectorising, in
            // debug builds)
            let at = (y0 as u32).wrapping_mul(size.width).wrapping_add(x0 as u32);
            offset[l] = if ok { at } else { 0 };
            for k in 0..4 {
                w[k][l] = if ok { q[k] } else { 0 };
            }
        }
        // (three times an offset fits a u32: `plain_table` checks the source's size)
        (
            round_of(&offset, &w),
            inside,
            offset.into_iter().max().unwrap_or(0),
        )
    }
}

impl Builder<'_> {
    /// Bearings `d` (x, y, z lanes in the output's axes) in the source's axes, with
    /// nalgebra's product's operations: `src_from_dst * d`, bit for bit.
    #[inline(always)]
    fn turn(&self, d: [Lanes; 3]) -> [Lanes; 3] {
        let r = self.src_from_dst;
        let mut turned = [[0.0; LANES]; 3];
        for (i, t) in turned.iter_mut().enumerate() {
            let (r0, r1, r2) = (r[(i, 0)], r[(i, 1)], r[(i, 2)]);
            for l in 0..LANES {
                // nalgebra's product: (r0·x + r1·y) + r2·z
                t[l] = r0 * d[0][l] + r1 * d[1][l] + r2 * d[2][l];
            }
        }
        turned
    }

    /// [`Builder::centres`] of a separable output from a pinhole source of intrinsics `k`:
    /// the source positions of row `v`'s centres, columns -1..=width, where the columns from
    /// `lo` on with shares `kept` are mapped (None elsewhere), a group of lanes at a time with
    /// `project`'s very operations (None where it rejects: a NaN lane). `xyz`: scratch.
    pub(super) fn centres_lanes(
        &self,
        sep: &dyn Separable,
        k: &Intrinsics,
        (v, lo): (isize, isize),
        kept: &[Share],
        xyz: &mut [Vec<f64>; 3],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (checked just above).
            return unsafe { self.centres_lanes_avx2(sep, k, (v, lo), kept, xyz, out) };
        }
        self.centres_lanes_any(sep, k, (v, lo), kept, xyz, out)
    }

    /// [`Builder::centres_lanes`] compiled for AVX2 (the same IEEE operations, the same bits).
    ///
    /// # Safety
    ///
    /// The processor must have AVX2 (`is_x86_feature_detected!("avx2")`). It reads and writes
    /// only through safe slices.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn centres_lanes_avx2(
        &self,
        sep: &dyn Separable,
        k: &Intrinsics,
        at: (isize, isize),
        kept: &[Share],
        xyz: &mut [Vec<f64>; 3],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        self.centres_lanes_any(sep, k, at, kept, xyz, out)
    }

    #[inline(always)]
    fn centres_lanes_any(
        &self,
        sep: &dyn Separable,
        k: &Intrinsics,
        (v, lo): (isize, isize),
        kept: &[Share],
        xyz: &mut [Vec<f64>; 3],
        out: &mut Vec<Option<Point2<f64>>>,
    ) {
        let w = self.dst.size().width as usize;
        out.clear();
        out.resize((lo + 1).max(0) as usize, None);
        self.pinhole_groups(sep, k, v, kept, xyz, |_, [px, py], count| {
            out.extend((0..count).map(|l| (!px[l].is_nan()).then(|| Point2::new(px[l], py[l]))));
        });
        out.resize(w + 2, None);
    }

    /// The source positions of the output row `v`'s pixel centres of column shares `kept`
    /// through pinhole `k`, a group of [`LANES`] at a time: `emit(group, [x, y], count)`, the
    /// last group's spare lanes NaN (no position). `xyz`: scratch for the bearings.
    #[inline(always)]
    pub(super) fn pinhole_groups(
        &self,
        sep: &dyn Separable,
        k: &Intrinsics,
        v: isize,
        kept: &[Share],
        xyz: &mut [Vec<f64>; 3],
        mut emit: impl FnMut(usize, [Lanes; 2], usize),
    ) {
        let n = kept.len();
        if n == 0 {
            return;
        }
        for c in xyz.iter_mut() {
            c.clear();
            c.resize(n.next_multiple_of(LANES), f64::NAN);
        }
        let [x, y, z] = xyz;
        sep.bearing_lanes(
            kept,
            sep.row(v as f64),
            [&mut x[..n], &mut y[..n], &mut z[..n]],
        );
        for g in 0..n.div_ceil(LANES) {
            let lanes = g * LANES..(g + 1) * LANES;
            let d = [&x[lanes.clone()], &y[lanes.clone()], &z[lanes]]
                .map(|c| <Lanes>::try_from(c).expect("a group"));
            emit(g, pinhole_lanes(k, self.turn(d)), LANES.min(n - g * LANES));
        }
    }
}

/// `f64::clamp(x, 0.0, max)` for `max >= 0`, as selects.
#[inline(always)]
fn clamp(x: f64, max: f64) -> f64 {
    let x = if x < 0.0 { 0.0 } else { x };
    if x > max {
        max
    } else {
        x
    }
}

/// A group's round from its lanes' block offsets (source pixels; three times each must fit a
/// u32, which the callers' size checks ensure) and integer weights (top-left, bottom-left,
/// top-right, bottom-right, by lane).
#[inline(always)]
pub(super) fn round_of(offset: &[u32; LANES], w: &[[i32; LANES]; 4]) -> Round {
    let mut round = Round::default();
    for l in 0..LANES {
        round.offset[l] = offset[l].wrapping_mul(3);
        round.w[l] = [w[0][l], w[1][l], w[2][l], w[3][l]].map(|w| w as i16);
    }
    round
}

/// `quantize_block(_, weights, WEIGHT_ONE, WEIGHT_ONE)`'s integer weights (see
/// [`quantize_as`]).
#[inline(always)]
fn quantize(weights: [f64; 4]) -> [i32; 4] {
    quantize_as(weights, WEIGHT_ONE as f64, WEIGHT_ONE)
}

/// `quantize_block(_, weights, total, scale)`'s integer weights, as selects: each weight
/// times `scale` rounded, the largest (the first on ties) taking up the rounding error so that
/// they sum to `total`.
#[inline(always)]
pub(super) fn quantize_as(weights: [f64; 4], scale: f64, total: i32) -> [i32; 4] {
    let [y0, y1, y2, y3] = [
        weights[0] * scale,
        weights[1] * scale,
        weights[2] * scale,
        weights[3] * scale,
    ];
    // SAFETY: 0 <= y + 0.5 <= WEIGHT_ONE + 0.5 (the weights of points inside the source, at
    // most two taps at half the scale)
    let q = [y0, y1, y2, y3].map(|y| unsafe { (y + 0.5).to_int_unchecked::<i32>() });
    let (big, top) = (0, y0);
    let (big, top) = if y1 > top { (1, y1) } else { (big, top) };
    let (big, top) = if y2 > top { (2, y2) } else { (big, top) };
    let big = if y3 > top { 3 } else { big };
    // (small numbers: wrapping operations that cannot wrap, without overflow checks)
    let sum = q[0]
        .wrapping_add(q[1])
        .wrapping_add(q[2])
        .wrapping_add(q[3]);
    let fix = total.wrapping_sub(sum);
    [
        q[0].wrapping_add(if big == 0 { fix } else { 0 }),
        q[1].wrapping_add(if big == 1 { fix } else { 0 }),
        q[2].wrapping_add(if big == 2 { fix } else { 0 }),
        q[3].wrapping_add(if big == 3 { fix } else { 0 }),
    ]
}

/// `round` with the lanes past the row's end (its last `n` pixels are the group's first) as
/// [`RemapTable::round`] fills them: copies of the group's first lane.
#[inline(always)]
fn tail(mut round: Round, n: usize) -> Round {
    for lane in n.min(LANES)..LANES {
        round.offset[lane] = round.offset[0];
        round.w[lane] = round.w[0];
    }
    round
}

#[cfg(test)]
mod tests {
    use crate::camera::{
        rotation_ypr, CameraModel, Fisheye, ImageSize, Intrinsics, Perspective, Projection,
        ProjectionReject, RadialModel,
    };
    use crate::warp::{Footprint, RemapTable, Wrap};
    use nalgebra::{Point2, Vector3};

    /// `inner` through `project` and `unproject` alone: the builder's per-pixel path.
    #[derive(Debug)]
    struct PerPixel<'a>(&'a dyn CameraModel);

    impl CameraModel for PerPixel<'_> {
        fn project(&self, d: &Vector3<f64>) -> Result<Point2<f64>, ProjectionReject> {
            self.0.project(d)
        }
        fn unproject(&self, p: &Point2<f64>) -> Result<Vector3<f64>, ProjectionReject> {
            self.0.unproject(p)
        }
        fn distance(&self, p: &Vector3<f64>) -> f64 {
            self.0.distance(p)
        }
        fn size(&self) -> ImageSize {
            self.0.size()
        }
    }

    #[test]
    fn drawn_views_of_a_pinhole_equal_the_per_pixel_tables() {
        // a small KITTI-like source; turned views drawn as the Python sampler draws them,
        // with widths that leave a part group at each row's end and views wider than the
        // source (blank rows and groups), within their footprint and without one
        let src = Perspective::new(
            Intrinsics::new(180.4, 180.4, 152.4, 43.2),
            ImageSize::new(310, 94),
        );
        let mut s = 7u64;
        let mut r = |lo: f64, hi: f64| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
        };
        let mut covered = 0.0;
        for i in 0..36 {
            let projection = [
                Projection::Cylindrical,
                Projection::Equirect,
                Projection::Perspective,
            ][i % 3];
            let (w, h) = (100 + (i as u32 * 37) % 61, 60 + (i as u32 * 11) % 41);
            let fov = r(0.8, 2.2);
            let fu = if projection == Projection::Perspective {
                w as f64 / 2.0 / (fov / 2.0).tan()
            } else {
                w as f64 / fov
            };
            let k = Intrinsics::new(
                fu,
                fu * r(0.9, 1.1),
                w as f64 / 2.0 + r(-8.0, 8.0),
                h as f64 / 2.0 + r(-8.0, 8.0),
            );
            let dst = projection.camera(k, ImageSize::new(w, h));
            let rot = rotation_ypr(r(-0.3, 0.3), r(-0.2, 0.2), r(-0.1, 0.1));
            let want = RemapTable::build_within(
                &PerPixel(dst.as_ref()),
                &PerPixel(&src),
                &rot,
                Wrap::None,
                1,
                None,
                false,
            );
            let seen = Footprint::new(dst.as_ref(), &src, &rot, &-Vector3::z());
            for seen in [None, seen.as_ref()] {
                let got =
                    RemapTable::build_within(dst.as_ref(), &src, &rot, Wrap::None, 1, seen, false);
                assert!(got == want, "{projection} {i}: the tables differ");
            }
            covered += want.coverage();
        }
        assert!(covered > 36.0 * 0.1 && covered < 36.0 * 0.95, "{covered}");
    }

    #[test]
    fn the_python_benchmarks_views_equal_the_per_pixel_pyramid_tables() {
        // benches/random_cameras.py's three 640×480 views of a KITTI frame (a 190°
        // Kannala-Brandt lens, an equirect crop of 120°, a cylindrical view of 105°), turned
        // and off centre, within their footprint and without: the pyramid's table of the
        // pinhole source (the linear views' groups of one-tap pixels made in lanes,
        // `lanes/pyramid.rs`) is the per-pixel one, entry for entry
        let src = Perspective::new(
            Intrinsics::new(721.5, 721.5, 609.6, 172.9),
            ImageSize::new(1242, 375),
        );
        let lens = crate::camera::Fisheye::new(
            crate::camera::RadialModel::KannalaBrandt([0.02, -0.004, 0.0, 0.0]),
            Intrinsics::new(166.5, 166.5, 323.5, 236.0),
            ImageSize::new(640, 480),
            190f64.to_radians(),
        )
        .expect("a lens");
        let view = |projection: Projection, fov: f64| {
            let f = 640.0 / fov.to_radians();
            let k = Intrinsics::new(f, f * 1.02, 317.0, 244.5);
            projection.camera(k, ImageSize::new(640, 480))
        };
        let (crop, cylinder) = (
            view(Projection::Equirect, 120.0),
            view(Projection::Cylindrical, 105.0),
        );
        let cameras: [(&str, &dyn CameraModel); 3] = [
            ("fisheye", &lens),
            ("equirect crop", crop.as_ref()),
            ("cylindrical", cylinder.as_ref()),
        ];
        let rot = rotation_ypr(0.12, -0.07, 0.04);
        for (name, dst) in cameras {
            let seen = Footprint::new(dst, &src, &rot, &-Vector3::z());
            assert!(seen.is_some(), "{name}: a footprint");
            for seen in [None, seen.as_ref()] {
                let build = |src: &dyn CameraModel| {
                    RemapTable::build_pyramid_within(dst, src, &rot, Wrap::None, 8, seen, false)
                };
                let want = build(&PerPixel(&src));
                // (levels: the source and its halves at least)
                assert!(want.levels >= 2, "{name}: {} levels", want.levels);
                assert!(build(&src) == want, "{name}: the tables differ");
            }
        }
    }

    #[test]
    fn drawn_pyramid_tables_equal_the_per_pixel_ones() {
        // views a few times coarser than the source (levels 1 to 3 sampled, anisotropic
        // pixels taking several taps beside the one-tap ones), turned, serial and parallel,
        // within their footprint and without: the centres mapped in lanes give the table of
        // the centres mapped one by one, entry for entry
        let src = Perspective::new(
            Intrinsics::new(360.8, 360.8, 304.8, 86.4),
            ImageSize::new(620, 188),
        );
        let mut s = 11u64;
        let mut r = |lo: f64, hi: f64| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            lo + (hi - lo) * ((s >> 11) as f64 / (1u64 << 53) as f64)
        };
        let (mut levels, mut covered) = ([0; 5], 0.0);
        for i in 0..40 {
            // (every fourth a Kannala-Brandt lens: no column and row shares, its centres
            // unprojected one by one, the rest of its build in lanes as the linear views')
            let projection = [
                Some(Projection::Cylindrical),
                Some(Projection::Equirect),
                Some(Projection::Perspective),
                None,
            ][i % 4];
            let (w, h) = (60 + (i as u32 * 37) % 241, 30 + (i as u32 * 11) % 91);
            let fov = r(0.8, 3.0);
            let fu = match projection {
                Some(Projection::Perspective) => w as f64 / 2.0 / (fov / 2.0).tan(),
                _ => w as f64 / fov,
            };
            let k = Intrinsics::new(
                fu,
                fu * r(0.6, 1.4),
                w as f64 / 2.0 + r(-8.0, 8.0),
                h as f64 / 2.0 + r(-8.0, 8.0),
            );
            let size = ImageSize::new(w, h);
            let dst: Box<dyn CameraModel> = match projection {
                None => Box::new(
                    Fisheye::new(
                        RadialModel::KannalaBrandt([r(-0.03, 0.03), r(-0.01, 0.01), 0.0, 0.0]),
                        k,
                        size,
                        r(1.2, 1.65),
                    )
                    .expect("a lens"),
                ),
                Some(projection) => projection.camera(k, size),
            };
            let projection = projection.map_or("fisheye".into(), |p| p.to_string());
            let rot = rotation_ypr(r(-0.3, 0.3), r(-0.2, 0.2), r(-0.1, 0.1));
            // (the source without `pinhole`: its centres mapped by `project`, one by one; the
            // output's taps still by column and row shares, as the lanes' build maps them)
            let seen = Footprint::new(dst.as_ref(), &src, &rot, &-Vector3::z());
            let build = |src: &dyn CameraModel, seen, parallel| {
                RemapTable::build_pyramid_within(
                    dst.as_ref(),
                    src,
                    &rot,
                    Wrap::None,
                    8,
                    seen,
                    parallel,
                )
            };
            for seen in [None, seen.as_ref()] {
                // (a lens's reference is the per-pixel build from the pinhole itself: a pinhole
                // keeps a pair's interpolation on its axis's bend alone, `local_pair`, which
                // a lens's rim tells from the general source's rule)
                let want = match projection.as_str() {
                    "fisheye" => {
                        super::pyramid::PER_PIXEL_ONLY.set(true);
                        let want = build(&src, seen, false);
                        super::pyramid::PER_PIXEL_ONLY.set(false);
                        want
                    }
                    _ => build(&PerPixel(&src), seen, false),
                };
                for parallel in [false, true] {
                    let got = build(&src, seen, parallel);
                    assert!(
                        got == want,
                        "{projection} {i} ({parallel}): the tables differ"
                    );
                }
                levels[want.levels as usize] += 1;
                covered += want.coverage();
            }
        }
        // (levels: the tables' counts; 4 where level 3 is sampled) the cases reach the coarse
        // and the finer levels, and both the source's inside and outside
        assert!(levels[4] > 10 && levels[2] + levels[3] > 10, "{levels:?}");
        assert!(covered > 80.0 * 0.1 && covered < 80.0 * 0.98, "{covered}");
    }
}
