//! One pinhole camera of a grid-guided stitch: where it sees a point of the scene (a few flops
//! a pixel), how wide an output pixel is in its image, its blend weight there, and its two
//! occlusion buffers, the nearest depth per cell of [`CELL`]×[`CELL`] source pixels: of the
//! scan's returns but the ground's, each splatted over half its rings' and azimuth steps'
//! spacing (noisy: a wide margin), and of the boxes where they were when it fired, ray-cast at each cell's
//! corners and middle (exact: a narrow margin, and never against the point's own box).

use super::distance::slab;
use super::{GridBox, GridScene};
use crate::camera::Intrinsics;
use crate::warp::mask::EgoMask;
use crate::warp::stitch::StitchCamera;
use nalgebra::{Matrix3, Point2, Vector3};

/// Occlusion buffer cell, source pixels.
const CELL: usize = 8;
/// Half the angular spacing a return covers: across the rings and along them (the scanners
/// read are 0.17-1.33° apart across and 0.1-0.35° along), radians.
const SPLAT_ACROSS: f64 = 0.0061;
const SPLAT_ALONG: f64 = 0.0026;
/// A return in a camera's scan buffer hides the point only when nearer by more than this
/// margin plus [`SCAN_SHARE`] and the ring spacing (radians) of the point's depth (the scan's
/// noise, the buffer's cells, and a return's bearing uncertain by up to a spacing).
const SCAN_MARGIN: f32 = 0.3;
const SCAN_SHARE: f32 = 0.1;
/// A box in its box buffer, by more than this margin plus [`BOX_SHARE`] of the depth.
const BOX_MARGIN: f32 = 0.05;
const BOX_SHARE: f32 = 0.01;
/// A camera nearer the output centre than this (metres, its boxes' moves included) is never
/// occluded.
const AT_CENTRE: f64 = 1e-3;
/// A box buffer cell without a box.
const NO_BOX_CELL: (f32, u16) = (f32::MAX, u16::MAX);
/// Nearest depth a camera samples, metres.
const MIN_DEPTH: f64 = 0.05;

/// A camera's view of one point.
#[derive(Debug, Clone, Copy)]
pub(super) struct View {
    pub(super) x: f32,
    pub(super) y: f32,
    /// log2 of the source pixels an output pixel spans there.
    pub(super) lod: f32,
    /// The blend weight (step 3 of the stitch's model).
    pub(super) weight: f32,
    /// Something of the scene lies clearly nearer on the camera's ray.
    pub(super) occluded: bool,
}

pub(super) struct GridCamera<'a> {
    rotation: Matrix3<f64>,
    /// The output centre in the camera's axes.
    origin: Vector3<f64>,
    k: Intrinsics,
    width: f64,
    height: f64,
    /// The larger focal length: pixels per radian on the axis.
    focal: f64,
    /// The image border planes' inward unit normals (through the eye).
    planes: [Vector3<f64>; 4],
    /// The eye's distance from the output centre plus the farthest a box moves for it.
    offset: f64,
    /// Per box, its move to the camera's time, in the camera's axes.
    moved: Vec<Vector3<f64>>,
    mask: Option<&'a EgoMask>,
    /// [`SCAN_SHARE`] and the scan's ring spacing.
    scan_share: f32,
    /// The scan's buffer, and the boxes' (depth, box index), row-major.
    scan: Vec<f32>,
    boxes: Vec<(f32, u16)>,
    buffer_width: usize,
}

impl<'a> GridCamera<'a> {
    /// The camera `camera` (a pinhole: `k`) of a stitch from `centre`, its buffer of `scene`.
    pub(super) fn new(
        (index, camera, k): (usize, &StitchCamera, Intrinsics),
        centre: &Vector3<f64>,
        scene: &GridScene,
        mask: Option<&'a EgoMask>,
    ) -> Self {
        let size = camera.model.size();
        let rotation = camera.rotation;
        let moved: Vec<Vector3<f64>> = scene
            .boxes
            .iter()
            .map(|b| rotation * b.moved.get(index).copied().unwrap_or_else(Vector3::zeros))
            .collect();
        let origin = rotation * centre + camera.translation;
        let mut c = GridCamera {
            rotation,
            origin,
            k,
            width: size.width as f64,
            height: size.height as f64,
            focal: k.fu.max(k.fv),
            planes: border_planes(&k, size.width as f64, size.height as f64),
            offset: origin.norm() + moved.iter().map(|m| m.norm()).fold(0.0, f64::max),
            moved,
            mask,
            scan_share: SCAN_SHARE + scene.ring_spacing as f32,
            scan: Vec::new(),
            boxes: Vec::new(),
            buffer_width: 0,
        };
        c.splat_points(scene, centre);
        c.boxes = vec![NO_BOX_CELL; c.scan.len()];
        for (k, b) in scene.boxes.iter().enumerate() {
            let moved = c.moved[k];
            c.cast_box((k as u16, b), centre, &moved);
        }
        c
    }

    /// Whether the camera may see a point whose direction from the output centre lies within
    /// `radius` radians of unit bearing `b` (reference axes) at `nearest` metres or farther.
    pub(super) fn may_see(&self, b: &Vector3<f64>, radius: f64, nearest: f64) -> bool {
        // from the eye the point's direction turns by at most asin(offset / distance)
        let turn = radius + (self.offset / nearest.max(1e-9)).min(1.0).asin();
        if turn >= std::f64::consts::FRAC_PI_2 {
            return true;
        }
        let a = self.rotation * b;
        let slack = -turn.sin();
        self.planes.iter().all(|n| n.dot(&a) >= slack)
    }

    /// The camera's view of the point at `distance` along unit bearing `b` from the output
    /// centre (on box `on_box`'s face, moved to the camera's time), an output pixel `pixel`
    /// radians wide there, with a blend width of `blend` radians: None where its image does not
    /// hold the point (or its ego mask touches the sample).
    #[inline]
    pub(super) fn view(
        &self,
        b: &Vector3<f64>,
        distance: f64,
        on_box: Option<usize>,
        (pixel, blend): (f64, f64),
    ) -> Option<View> {
        let mut q = self.rotation * (b * distance) + self.origin;
        if let Some(m) = on_box.and_then(|k| self.moved.get(k)) {
            q += m;
        }
        if !(q.z > MIN_DEPTH) {
            return None;
        }
        let iz = 1.0 / q.z;
        let x = self.k.fu * q.x * iz + self.k.cu;
        let y = self.k.fv * q.y * iz + self.k.cv;
        // the border's margin, in pixels (edges at -0.5 and size - 0.5)
        let border = (x + 0.5)
            .min(y + 0.5)
            .min(self.width - 0.5 - x)
            .min(self.height - 0.5 - y);
        if !(border > 0.0) {
            return None;
        }
        // a pinhole's scale off its axis: f / cos²θ pixels a radian along the radius
        let scale = self.focal * q.norm_squared() * iz * iz;
        let spread = pixel * scale;
        if let Some(mask) = self.mask {
            let reach = 1.0 + spread.max(1.0);
            if mask.touches(&Point2::new(x, y), reach) {
                return None;
            }
        }
        let t = (border / scale / blend).min(1.0);
        let depth = q.z as f32;
        // the cells within the sample's footprint: half its spread and the bilinear tap (the
        // tails of its trilinear taps beyond weigh little)
        let (scan, (boxed, by)) = self.nearest_around(x, y, 1.0 + spread / 2.0, on_box);
        // (a camera at the output centre sees along the output's own ray: nothing hides
        // the point from it)
        let occluded = self.offset > AT_CENTRE
            && (scan < depth - (SCAN_MARGIN + self.scan_share * depth)
                || (boxed < depth - (BOX_MARGIN + BOX_SHARE * depth)
                    && on_box != Some(by as usize)));
        Some(View {
            x: x as f32,
            y: y as f32,
            lod: spread.max(1e-9).log2() as f32,
            weight: (t * t * (3.0 - 2.0 * t)) as f32,
            occluded,
        })
    }

    /// The nearest depths the buffers hold within `reach` source pixels of (x, y) in x and
    /// y: the scan's, and the nearest box's other than `own` with its index.
    #[inline]
    fn nearest_around(&self, x: f64, y: f64, reach: f64, own: Option<usize>) -> (f32, (f32, u16)) {
        // (exact: a power of two; a cast truncates, which is the floor of what max leaves)
        let per_cell = 1.0 / CELL as f64;
        let rows = self.scan.len() / self.buffer_width.max(1);
        let span = |a: f64, n: usize| {
            let lo = ((a - reach + 0.5) * per_cell).max(0.0) as usize;
            let hi = (((a + reach + 0.5) * per_cell).max(0.0) as usize).min(n.max(1) - 1);
            lo..=hi
        };
        let (columns, rows) = (span(x, self.buffer_width), span(y, rows));
        let own = own.map_or(u16::MAX, |k| k as u16);
        let (mut scan, mut boxed) = (f32::MAX, NO_BOX_CELL);
        for r in rows {
            let at = r * self.buffer_width;
            for z in &self.scan[at..][columns.clone()] {
                scan = scan.min(*z);
            }
            for b in &self.boxes[at..][columns.clone()] {
                // (a cell holds one box: the point's own box there hides nothing)
                if b.0 < boxed.0 && b.1 != own {
                    boxed = *b;
                }
            }
        }
        (scan, boxed)
    }

    /// The scan's returns but the ground's into the buffer: each return's depth, nearest per
    /// cell, over half the ring spacing (at least ±[`SPLAT_ACROSS`]) vertically and
    /// ±[`SPLAT_ALONG`] horizontally, so that a surface between rings covers its cells.
    fn splat_points(&mut self, scene: &GridScene, centre: &Vector3<f64>) {
        let (bw, bh) = (
            (self.width as usize).div_ceil(CELL),
            (self.height as usize).div_ceil(CELL),
        );
        self.buffer_width = bw;
        self.scan = vec![f32::MAX; bw * bh];
        let cell = CELL as f64;
        let across = SPLAT_ACROSS.max(scene.ring_spacing / 2.0);
        let (hv, hu) = (self.k.fv * across / cell, self.k.fu * SPLAT_ALONG / cell);
        // (the ground's returns hide nothing: a road seen at a grazing angle is rings metres
        // apart, each nearer than the road beyond it)
        let above_ground = (scene.points.iter().zip(&scene.on_ground)).filter(|(_, g)| !**g);
        for (p, _) in above_ground {
            let q = self.rotation * (p - centre) + self.origin;
            if q.z < 0.3 {
                continue;
            }
            let u = (self.k.fu * q.x / q.z + self.k.cu) / cell;
            let v = (self.k.fv * q.y / q.z + self.k.cv) / cell;
            let (c0, c1) = ((u - hu).max(0.0), (u + hu).min(bw as f64 - 1.0));
            let (r0, r1) = ((v - hv).max(0.0), (v + hv).min(bh as f64 - 1.0));
            if !(c0 <= c1 && r0 <= r1) {
                continue;
            }
            for row in r0 as usize..=r1 as usize {
                for z in &mut self.scan[row * bw + c0 as usize..=row * bw + c1 as usize] {
                    *z = z.min(q.z as f32);
                }
            }
        }
    }

    /// Box `b` (index `k`, moved by `moved`, camera axes) into the box buffer, nearest box
    /// winning: its entry depth along the rays
    /// through each cell's corners and middle, over the cells its image may cover (bounded by
    /// its corners ahead and its edges' crossings of the plane z = 0.1 m).
    fn cast_box(&mut self, (k, b): (u16, &GridBox), centre: &Vector3<f64>, moved: &Vector3<f64>) {
        let rot = self.rotation;
        // box centre and corners in the camera's axes
        let c = rot * (b.centre - centre) + self.origin + moved;
        let q: Vec<Vector3<f64>> = b
            .corners()
            .iter()
            .map(|x| rot * (x - b.centre) + c)
            .collect();
        let Some(cells) = self.box_cells(&q) else {
            return;
        };
        let (x0, y0, nx, ny) = cells;
        // the ray through source position (x, y) in the box's own axes, from the eye
        let to_box = b.rotation.transpose() * rot.transpose();
        let o = -(b.rotation.transpose() * (rot.transpose() * c));
        let cast = |x: f64, y: f64| {
            let dir = Vector3::new(
                (x - self.k.cu) / self.k.fu,
                (y - self.k.cv) / self.k.fv,
                1.0,
            );
            slab(&o, &(to_box * dir), &b.half).map_or(f32::MAX, |z| z as f32)
        };
        let cell = CELL as f64;
        // corners cast once (shared by four cells), each cell's middle alone
        let corners: Vec<f32> = (0..=ny)
            .flat_map(|j| (0..=nx).map(move |i| (i, j)))
            .map(|(i, j)| cast((x0 + i) as f64 * cell - 0.5, (y0 + j) as f64 * cell - 0.5))
            .collect();
        for j in 0..ny {
            for i in 0..nx {
                let at = j * (nx + 1) + i;
                let mid = cast(
                    (x0 + i) as f64 * cell + cell / 2.0 - 0.5,
                    (y0 + j) as f64 * cell + cell / 2.0 - 0.5,
                );
                let z = mid
                    .min(corners[at])
                    .min(corners[at + 1])
                    .min(corners[at + nx + 1])
                    .min(corners[at + nx + 2]);
                let cell = &mut self.boxes[(y0 + j) * self.buffer_width + x0 + i];
                if z < cell.0 {
                    *cell = (z, k);
                }
            }
        }
    }

    /// The buffer's cells (first column, first row, columns, rows) a box with corners `q`
    /// (camera axes) may cover; None where it covers none.
    fn box_cells(&self, q: &[Vector3<f64>]) -> Option<(usize, usize, usize, usize)> {
        const NEAR: f64 = 0.1;
        let mut points: Vec<Vector3<f64>> = q.iter().filter(|p| p.z >= NEAR).copied().collect();
        if points.is_empty() {
            return None;
        }
        for a in 0..8 {
            for bit in [1, 2, 4] {
                let b = a | bit;
                if b != a && (q[a].z >= NEAR) != (q[b].z >= NEAR) {
                    let t = (NEAR - q[a].z) / (q[b].z - q[a].z);
                    points.push(q[a] + (q[b] - q[a]) * t);
                }
            }
        }
        let (mut c0, mut c1, mut r0, mut r1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for p in &points {
            let z = p.z.max(NEAR);
            let (x, y) = (
                self.k.fu * p.x / z + self.k.cu,
                self.k.fv * p.y / z + self.k.cv,
            );
            (c0, c1, r0, r1) = (c0.min(x), c1.max(x), r0.min(y), r1.max(y));
        }
        let cell = CELL as f64;
        let bh = self.scan.len() / self.buffer_width.max(1);
        let (cx0, cx1) = (
            ((c0 + 0.5) / cell).floor().max(0.0),
            ((c1 + 0.5) / cell)
                .floor()
                .min(self.buffer_width as f64 - 1.0),
        );
        let (cy0, cy1) = (
            ((r0 + 0.5) / cell).floor().max(0.0),
            ((r1 + 0.5) / cell).floor().min(bh as f64 - 1.0),
        );
        (cx0 <= cx1 && cy0 <= cy1).then(|| {
            let (x0, y0) = (cx0 as usize, cy0 as usize);
            (x0, y0, cx1 as usize - x0 + 1, cy1 as usize - y0 + 1)
        })
    }
}

/// The inward unit normals of a pinhole's four border planes (through the eye and the image's
/// edges at -0.5 and size - 0.5).
fn border_planes(k: &Intrinsics, w: f64, h: f64) -> [Vector3<f64>; 4] {
    let (xl, xr) = ((-0.5 - k.cu) / k.fu, (w - 0.5 - k.cu) / k.fu);
    let (yt, yb) = ((-0.5 - k.cv) / k.fv, (h - 0.5 - k.cv) / k.fv);
    // x >= xl·z  <=>  (1, 0, -xl)·q >= 0, and so on
    [
        Vector3::new(1.0, 0.0, -xl).normalize(),
        Vector3::new(-1.0, 0.0, xr).normalize(),
        Vector3::new(0.0, 1.0, -yt).normalize(),
        Vector3::new(0.0, -1.0, yb).normalize(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraModel, ImageSize, Perspective};

    /// A facade 5 m ahead scanned by rings `spacing` apart (the scene's measured spacing
    /// `measured`), seen by a pinhole 0.5 m beside the output centre.
    fn facade_camera(spacing: f64, measured: f64, test: impl FnOnce(&GridCamera)) {
        let lens = Perspective::new(
            Intrinsics::new(500.0, 500.0, 319.5, 239.5),
            ImageSize::new(640, 480),
        );
        let camera = StitchCamera {
            model: &lens,
            rotation: Matrix3::identity(),
            translation: Vector3::new(-0.5, 0.0, 0.0),
            max_theta: None,
        };
        let mut points = Vec::new();
        for ring in -3..=3 {
            let elevation = ring as f64 * spacing;
            for step in -100..=100 {
                let azimuth = (step as f64 * 0.1f64).to_radians();
                // (the reference frame's y points down)
                let d = Vector3::new(
                    azimuth.sin() * elevation.cos(),
                    -elevation.sin(),
                    azimuth.cos() * elevation.cos(),
                );
                points.push(d * (5.0 / d.z));
            }
        }
        let scene = GridScene {
            on_ground: vec![false; points.len()],
            ground_normal: None,
            points,
            ring_spacing: measured,
            boxes: Vec::new(),
            ground: None,
        };
        let k = lens.pinhole().unwrap();
        test(&GridCamera::new(
            (0, &camera, k),
            &Vector3::zeros(),
            &scene,
            None,
        ));
    }

    /// Whether the camera finds the point `distance` along bearing (azimuth 0, `elevation`)
    /// hidden.
    fn hidden(camera: &GridCamera, elevation: f64, distance: f64) -> bool {
        let b = Vector3::new(0.0, -elevation.sin(), elevation.cos());
        let view = camera
            .view(&b, distance, None, (1e-3, 0.1))
            .expect("in the image");
        view.occluded
    }

    #[test]
    fn rings_far_apart_cover_the_facade_between_them_and_widen_the_margin() {
        let spacing = 3f64.to_radians();
        let middle = spacing / 2.0;
        // the facade between two rings hides the point 10 m behind it only when the buffer
        // knows the rings are 3° apart (half a spacing each side of a ring): with the
        // splat's least extent the middle of the gap is open
        facade_camera(spacing, spacing, |c| assert!(hidden(c, middle, 10.0)));
        facade_camera(spacing, 0.0, |c| assert!(!hidden(c, middle, 10.0)));
        // on a ring: a return 1.1 m in front of a point 6.1 m away hides it where the
        // margin is 0.3 m and 10 % (+ 0.2 % for rings 0.1° apart), not where it grows by
        // the 3° spacing's 5.2 % of the depth
        facade_camera(spacing, 0.1f64.to_radians(), |c| {
            assert!(hidden(c, 0.0, 6.1))
        });
        facade_camera(spacing, spacing, |c| assert!(!hidden(c, 0.0, 6.1)));
    }
}
