//! Makes docs/images/occlusion_{zbuffer,filtered}.png: the synthetic frame 000000 in equirect
//! with its LiDAR depth pixels coloured by truth — green where the depth is the visible
//! surface's (within 5 %), red where the point is seen through an occluder — for a plain
//! nearest-point z-buffer and with the occlusion filter.
//!
//!     cargo run --release --example occlusion_figure -- docs/images

use nalgebra::{Matrix3, Matrix3x4, Point2, Vector3};
use panoconv::camera::{Perspective, Projection};
use panoconv::codec::png::{encode_rgb8, PngCompression};
use panoconv::geometry::{output_camera, OutputSpec};
use panoconv::kitti::velodyne::rect_from_velo;
use panoconv::reproject::depth::{depth_map, OcclusionFilter};
use panoconv::tools::synth::{frames, SynthCalib};
use panoconv::warp::{RemapTable, Wrap};

fn main() {
    let dir = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/images".into());
    let f = &frames()[0];
    let src = Perspective::new(f.calib.intrinsics(), f.calib.size);
    let out = output_camera(
        &OutputSpec::new(Projection::Equirect),
        f.calib.intrinsics(),
        &src,
    )
    .unwrap();
    let image = RemapTable::build(out.as_ref(), &src, &Matrix3::identity(), Wrap::None)
        .apply(&f.scene.render(&src, &f.calib.centre()));
    let (r, t) = SynthCalib::rect_from_velo();
    let velo: Vec<Vector3<f64>> = f
        .scene
        .lidar_scan(&(r, t))
        .into_iter()
        .map(|(p, _)| p)
        .collect();
    let mut tr = Matrix3x4::zeros();
    tr.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    tr.set_column(3, &t);
    let rect = rect_from_velo(&velo, &Matrix3::identity(), &tr);
    let filter = OcclusionFilter::default();
    for (name, filter) in [("zbuffer", None), ("filtered", Some(&filter))] {
        let (map, _) = depth_map(
            rect.iter().copied(),
            &f.calib.centre(),
            out.as_ref(),
            &src,
            filter,
        );
        // darken the picture so the points stand out
        let mut img = image.clone();
        img.as_raw_mut().iter_mut().for_each(|v| *v /= 3);
        let (mut good, mut bad) = (0, 0);
        for v in 0..map.height {
            for u in 0..map.width {
                let d = map.values[(v * map.width + u) as usize];
                if d <= 0.0 {
                    continue;
                }
                let ray = out.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                let truth = f
                    .scene
                    .first_hit(&f.calib.centre(), &ray)
                    .map(|(t, _)| out.distance(&(ray * t)));
                let see_through = truth.is_some_and(|t| d > 1.05 * t);
                let colour = if see_through {
                    [255, 40, 40]
                } else {
                    [60, 220, 90]
                };
                if see_through {
                    bad += 1;
                } else {
                    good += 1;
                }
                // see-through points drawn bigger so they can be found
                let r = if see_through { 1 } else { 0 };
                for y in v.saturating_sub(r)..=(v + r).min(map.height - 1) {
                    for x in u.saturating_sub(r)..=(u + r).min(map.width - 1) {
                        img.put_pixel(x, y, colour);
                    }
                }
            }
        }
        let path = std::path::Path::new(&dir).join(format!("occlusion_{name}.png"));
        std::fs::write(&path, encode_rgb8(&img, PngCompression::Best)).unwrap();
        println!(
            "{}: {good} points on the visible surface, {bad} seen through an occluder",
            path.display()
        );
    }
}
