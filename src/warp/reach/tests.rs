//! The bound's shortcuts against the per-position computation they replace.

use super::*;
use crate::camera::{Equirect, Intrinsics, Perspective, Rotated};
use nalgebra::Rotation3;

/// A 400×200 equirect output (separable) and the same turned (not separable).
fn outputs() -> (Equirect, Rotated<Equirect>) {
    let equirect = || {
        let f = 400.0 / (2.0 * std::f64::consts::PI);
        Equirect::new(
            Intrinsics::new(f, f, 200.0, 100.0),
            ImageSize::new(400, 200),
        )
    };
    let turn = *Rotation3::from_euler_angles(0.3, -0.2, 0.1).matrix();
    (equirect(), Rotated::new(equirect(), turn))
}

/// Proxy-point maps of three cameras (10 m sphere, baselines up to 0.5 m), turned apart.
fn locals() -> Vec<impl Fn(&Vector3<f64>) -> Vector3<f64> + Sync> {
    [(0.0, 0.3), (1.9, -0.5), (-2.6, 0.2)]
        .into_iter()
        .map(|(yaw, x)| {
            let r = *Rotation3::from_euler_angles(0.1, yaw, 0.0).matrix();
            let t = Vector3::new(x, 0.1, -0.2);
            move |d: &Vector3<f64>| r * (d.normalize() * 10.0) + t
        })
        .collect()
}

#[test]
fn the_tiles_decide_every_position_as_the_positions_alone_do() {
    let (plain, turned) = outputs();
    let locals = locals();
    let near = |d: &Vector3<f64>, _radius: f64| 2.0 + 1.5 * d.y;
    // a 16:9 pinhole's border planes, widened per tile as the guided cone is
    let pinhole = Perspective::new(
        Intrinsics::new(300.0, 300.0, 191.5, 107.5),
        ImageSize::new(384, 216),
    );
    let planes = Frustum::of(&pinhole);
    for output in [&plain as &dyn CameraModel, &turned] {
        let output_grid = OutputGrid::compute(output);
        let tiles = tile_nearest(&output_grid, &near);
        let cases = [
            (0.45, false, None),
            (1.1, false, None),
            (0.6, true, None),
            (0.6, true, planes),
        ];
        for (half_angle, guided, frustum) in cases {
            let grid = Grid {
                output: &output_grid,
                tiles: guided.then_some(&tiles[..]),
            };
            for local in &locals {
                let cone = Cone {
                    local,
                    half_angle: Some(half_angle),
                    parallax: Some(if guided { 1.0 } else { 10.0 / 9.5 }),
                    baseline: guided.then_some(0.5),
                    frustum,
                };
                let tiled = cone_reach_by(&cone, &grid, true).unwrap();
                let alone = cone_reach_by(&cone, &grid, false).unwrap();
                assert!(tiled == alone, "{output:?} {half_angle} {guided}");
                // the planes leave out part of the guided cone's set
                if frustum.is_some() {
                    let round = Cone {
                        frustum: None,
                        ..cone
                    };
                    let round = cone_reach_by(&round, &grid, true).unwrap();
                    let (gw, gh) = (output_grid.gw, output_grid.gh);
                    let subset = (0..gh)
                        .all(|j| (0..gw).all(|i| !tiled.contains(i, j) || round.contains(i, j)));
                    let (cut, held) = (tiled.len(), round.len());
                    assert!(subset, "{output:?}");
                    assert!(cut < held, "{cut} of {held}");
                }
                // the cone holds some positions and leaves others
                let held = tiled.len();
                let all = output_grid.gw * output_grid.gh;
                assert!(held > 500 && held < all - 500, "{held}");
            }
        }
    }
}

#[test]
fn a_pinholes_planes_cut_its_cone_and_the_tiles_decide_them_as_the_positions_do() {
    let (plain, turned) = outputs();
    let locals = locals();
    // a 16:9 pinhole whose border cone is 33° wide: the planes leave out the cone's corners
    let camera = Perspective::new(
        Intrinsics::new(300.0, 300.0, 191.5, 107.5),
        ImageSize::new(384, 216),
    );
    let frustum = Frustum::of(&camera);
    assert!(frustum.is_some());
    for output in [&plain as &dyn CameraModel, &turned] {
        let output_grid = OutputGrid::compute(output);
        let grid = Grid {
            output: &output_grid,
            tiles: None,
        };
        for local in &locals {
            let cone = |frustum| Cone {
                local,
                half_angle: border_cone(&camera),
                parallax: Some(10.0 / 9.5),
                baseline: None,
                frustum,
            };
            let tiled = cone_reach_by(&cone(frustum), &grid, true).unwrap();
            let alone = cone_reach_by(&cone(frustum), &grid, false).unwrap();
            assert!(tiled == alone, "{output:?}");
            // within the cone's set, and a good part of it left out
            let round = cone_reach_by(&cone(None), &grid, true).unwrap();
            let (gw, gh) = (output_grid.gw, output_grid.gh);
            let subset =
                (0..gh).all(|j| (0..gw).all(|i| !tiled.contains(i, j) || round.contains(i, j)));
            assert!(subset, "{output:?}");
            let (cut, held) = (tiled.len(), round.len());
            assert!(
                cut > 500 && (cut as f64) < 0.8 * held as f64,
                "{cut} of {held}"
            );
        }
    }
}

#[test]
fn a_gated_row_is_what_the_gated_unproject_gives() {
    let (plain, turned) = outputs();
    let locals = locals();
    let camera = Perspective::new(
        Intrinsics::new(200.0, 200.0, 150.0, 100.0),
        ImageSize::new(300, 200),
    );
    for output in [&plain as &dyn CameraModel, &turned] {
        let cones: Vec<Cone> = locals
            .iter()
            .enumerate()
            .map(|(i, local)| Cone {
                local,
                half_angle: (i > 0).then(|| border_cone(&camera)).flatten(),
                parallax: Some(10.0 / 9.5),
                baseline: None,
                frustum: None,
            })
            .collect();
        let reach = Reach::new(output, &cones, None);
        let size = output.size();
        let (w, h) = (size.width as isize, size.height as isize);
        let mut refused = 0;
        for i in 0..cones.len() {
            let gated = Gated {
                output,
                reach: &reach,
                camera: i,
            };
            let mut row = Vec::new();
            for v in -1..=h {
                row.clear();
                assert!(gated.stored_centres(v, &mut row));
                let each: Vec<_> = (-1..=w)
                    .map(|u| gated.unproject(&Point2::new(u as f64, v as f64)).ok())
                    .collect();
                assert_eq!(row, each, "camera {i}, row {v}");
                refused += row.iter().filter(|d| d.is_none()).count();
            }
            assert!(!gated.stored_centres(h + 1, &mut row));
        }
        // the first camera's cone is unbounded, the others refuse most positions
        assert!(refused > (w * h) as usize, "{refused}");
    }
}

#[test]
fn a_kept_grid_is_the_computed_one_and_one_ulp_is_another_output() {
    let f = 400.0 / (2.0 * std::f64::consts::PI);
    let equirect =
        |cu: f64| Equirect::new(Intrinsics::new(f, f, cu, 100.0), ImageSize::new(400, 200));
    let (a, b) = (
        equirect(200.0),
        equirect(f64::from_bits(200f64.to_bits() + 1)),
    );
    let bits = |g: &OutputGrid| {
        let b: Vec<u64> = g
            .bearings
            .iter()
            .flat_map(|d| d.iter().map(|x| x.to_bits()))
            .collect();
        (b, g.step.to_bits(), g.complete.clone())
    };
    let fresh = OutputGrid::compute(&a);
    // the second call finds the first's grid (other tests may replace the kept one between
    // two calls: some pair of calls in twenty finds it)
    let reused = (0..20).any(|_| Arc::ptr_eq(&OutputGrid::of(&a), &OutputGrid::of(&a)));
    assert!(reused);
    assert_eq!(bits(&OutputGrid::of(&a)), bits(&fresh));
    // the output one ULP off is not served a's grid: its bearings differ
    let (kept_a, kept_b) = (OutputGrid::of(&a), OutputGrid::of(&b));
    assert_eq!(bits(&kept_b), bits(&OutputGrid::compute(&b)));
    assert_ne!(bits(&kept_a).0, bits(&kept_b).0);
}
