//! An ego mask keeps the car's body out of the stitch, and only there.

use super::*;
use nalgebra::{Point2, Vector3};
use panoconv::camera::CameraModel;
use panoconv::kitti360::Options;
use panoconv::tools::synth360::SEQUENCE;
use panoconv::warp::{EgoMask, Stitch, StitchOptions};

#[test]
fn an_ego_mask_keeps_the_cars_body_out_of_the_stitch() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/kitti360");
    let seq = Sequence::open(
        &root,
        SEQUENCE,
        Options {
            lidar: false,
            ..Options::default()
        },
    )
    .unwrap();
    let frame = seq.frame(250).unwrap();
    let size = ImageSize::new(360, 180);
    let (_, output) = full_equirect(size);
    let cameras = stitch_cameras(&frame, &seq);
    // the lower third of image_02 (350x350 here) is the car's side, as a grey PNG (any
    // non-zero value is the body)
    let fisheye = frame.rig[2].model.size();
    let (w, h) = (fisheye.width, fisheye.height);
    let body = |x: u32, y: u32| y >= 2 * h / 3 && x > 40 && x < w - 40;
    let tmp = tempfile::tempdir().unwrap();
    let mask_path = tmp.path().join("image_02_mask.png");
    let grey = common::Png {
        width: w,
        height: h,
        color: png::ColorType::Grayscale,
        depth: png::BitDepth::Eight,
        data: (0..h)
            .flat_map(|y| (0..w).map(move |x| if body(x, y) { 200 } else { 0 }))
            .collect(),
    };
    common::write_png(&mask_path, &grey);
    let mask = EgoMask::read(&mask_path, fisheye).unwrap();
    assert_eq!(
        mask.count() as u32,
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| body(x, y))
            .count() as u32
    );
    let options = StitchOptions::default();
    let plain = Stitch::build(&output, &Vector3::zeros(), &cameras, options);
    let masked = Stitch::build_masked(
        &output,
        &Vector3::zeros(),
        &cameras,
        &[None, None, Some(&mask)],
        options,
    )
    .unwrap();
    let mut images: Vec<RgbImage> = frame.rig.iter().map(|c| rgb(&c.image)).collect();
    let before = masked.apply(&images.iter().collect::<Vec<_>>());
    let unmasked = plain.apply(&images.iter().collect::<Vec<_>>());
    // paint the body magenta: the masked stitch does not change, the plain one does
    for y in 0..h {
        for x in 0..w {
            if body(x, y) {
                images[2].put_pixel(x, y, [255, 0, 255]);
            }
        }
    }
    let refs: Vec<&RgbImage> = images.iter().collect();
    let after = masked.apply(&refs);
    assert!(after.image == before.image && after.source == before.source);
    assert!(
        plain.apply(&refs).image != unmasked.image,
        "the body is not in the plain stitch"
    );
    // the pixels image_02 supplied over its body now come from the others or stay black
    let (mut moved, mut black) = (0, 0);
    for v in 0..size.height {
        for u in 0..size.width {
            let i = (v * size.width + u) as usize;
            if after.source[i] == 2 {
                // image_02's bilinear taps there (through the proxy point at 10 m) miss the body
                let d = output.unproject(&Point2::new(u as f64, v as f64)).unwrap();
                let q = cameras[2].rotation * (d * 10.0) + cameras[2].translation;
                let p = cameras[2].model.project_point(&q).unwrap();
                assert!(!mask.touches(&p, 1.0), "image_02's body at ({u}, {v})");
            }
            if unmasked.source[i] == 2 && masked.weight(2, u, v) == 0.0 {
                moved += 1;
                if after.source[i] == 255 {
                    black += 1;
                    assert_eq!(after.image.pixel(u, v), [0, 0, 0]);
                }
            } else {
                // elsewhere the weights that lead are untouched
                assert_eq!(after.source[i], unmasked.source[i], "({u}, {v})");
            }
        }
    }
    // ... but only there: image_02 still supplies the rest of its view
    let left = after.source.iter().filter(|s| **s == 2).count();
    eprintln!("ego mask: {moved} px moved off image_02 ({black} black), it supplies {left}");
    assert!(
        moved > 500 && black < moved && left > 5000,
        "{moved} {black} {left}"
    );
    // a mask of another size is refused, naming the file
    let e = EgoMask::read(&mask_path, ImageSize::new(w + 1, h)).unwrap_err();
    assert!(
        e.to_string().contains("image_02_mask.png") && e.to_string().contains("350x350"),
        "{e}"
    );
    let small = EgoMask::new(ImageSize::new(2, 2), vec![true; 4]).unwrap();
    let e = Stitch::build_masked(
        &output,
        &Vector3::zeros(),
        &cameras,
        &[Some(&small)],
        options,
    )
    .unwrap_err();
    assert!(e.to_string().contains("camera 0"), "{e}");
}
