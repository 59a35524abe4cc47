//! [`ImageMapping`]: one output camera's pixels from the N source cameras that give them, the
//! one type through which every conversion produces its images. N = 1 is a [`RemapTable`]
//! (built once per source camera and output camera, shared by every frame that has them); N > 1
//! is a frame's [`Stitch`]. Both give the image, the `--mask` image (where a source gives the
//! pixel) and the per-pixel source index. A source streamed from its PNG file as the encoder
//! takes rows is a table's alone ([`PngSource::warp_encode`](super::PngSource::warp_encode)
//! takes a [`RemapTable`]): a stitch cannot be handed one PNG file.

use super::stitch::{Stitch, Stitched};
use super::stream::warp_encode;
use super::table::RemapTable;
use crate::camera::ImageSize;
use crate::codec::png::{self, PngCompression};
use crate::image::RgbImage;

/// The source index of an output pixel that no source gives.
pub const NO_SOURCE: u8 = 255;

/// One output camera's pixels from N source cameras.
#[derive(Debug, Clone, Copy)]
pub enum ImageMapping<'a> {
    /// N = 1: one source camera's remap table.
    Single(&'a RemapTable),
    /// N > 1 (or a rig's cameras blended, ego masks and exposure gains included): the stitch
    /// of one frame's cameras.
    Stitch(&'a Stitch),
}

impl ImageMapping<'_> {
    /// The output image's size.
    pub fn size(&self) -> ImageSize {
        match self {
            ImageMapping::Single(table) => table.size(),
            ImageMapping::Stitch(stitch) => stitch.size(),
        }
    }

    /// How many source images [`ImageMapping::apply`] takes.
    pub fn sources(&self) -> usize {
        match self {
            ImageMapping::Single(_) => 1,
            ImageMapping::Stitch(stitch) => stitch.cameras(),
        }
    }

    /// The output image of `images` (one per source, in order, each of its camera's size).
    pub fn image(&self, images: &[&RgbImage]) -> RgbImage {
        match self {
            ImageMapping::Single(table) => table.apply(one(images)),
            ImageMapping::Stitch(stitch) => stitch.apply(images).image,
        }
    }

    /// The output image, each pixel's source index ([`NO_SOURCE`] for none) and each source's
    /// exposure gain (1 for a single source).
    pub fn apply(&self, images: &[&RgbImage]) -> Stitched {
        match self {
            ImageMapping::Single(table) => {
                let size = table.size();
                let source = (0..size.height)
                    .flat_map(|v| (0..size.width).map(move |u| (u, v)))
                    .map(|(u, v)| if table.is_inside(u, v) { 0 } else { NO_SOURCE })
                    .collect();
                Stitched {
                    image: table.apply(one(images)),
                    source,
                    gains: vec![1.0],
                }
            }
            ImageMapping::Stitch(stitch) => stitch.apply(images),
        }
    }

    /// The PNG file of the output image of decoded `images` (N = 1: warped row by row as the
    /// encoder takes the rows, never whole).
    pub fn encode(&self, images: &[&RgbImage], c: PngCompression) -> Vec<u8> {
        match self {
            ImageMapping::Single(table) => warp_encode(table, one(images), c),
            ImageMapping::Stitch(stitch) => png::encode_rgb8(&stitch.apply(images).image, c),
        }
    }

    /// Whether a source gives output pixel (u, v): every tap of its kernel inside the source
    /// image (N = 1), a camera of non-zero weight (N > 1).
    pub fn covers(&self, u: u32, v: u32) -> bool {
        match self {
            ImageMapping::Single(table) => table.is_inside(u, v),
            ImageMapping::Stitch(stitch) => {
                (0..stitch.cameras()).any(|i| stitch.weight(i, u, v) > 0.0)
            }
        }
    }

    /// The `--mask` image: a 1-bit PNG, white where [`ImageMapping::covers`].
    pub fn encode_mask(&self) -> Vec<u8> {
        let size = self.size();
        png::encode_mask(size.width, size.height, |u, v| self.covers(u, v))
    }
}

/// The one image of a single-source mapping.
fn one<'i>(images: &[&'i RgbImage]) -> &'i RgbImage {
    assert_eq!(images.len(), 1, "one image for a single-source mapping");
    images[0]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{Equirect, Intrinsics, Perspective};
    use crate::warp::{StitchCamera, StitchOptions, Wrap};
    use nalgebra::{Matrix3, Rotation3, Vector3};

    fn pattern(w: u32, h: u32, seed: u32) -> RgbImage {
        let mut img = RgbImage::new(w, h);
        for y in 0..h {
            for x in 0..w {
                let rgb = [(x * 7 + seed) as u8, (y * 13) as u8, ((x ^ y) + seed) as u8];
                img.put_pixel(x, y, rgb);
            }
        }
        img
    }

    #[test]
    fn one_source_is_its_table_and_covers_where_the_table_is_inside() {
        let source = Perspective::new(
            Intrinsics::new(80.0, 80.0, 59.5, 39.5),
            ImageSize::new(120, 80),
        );
        let output = Perspective::new(
            Intrinsics::new(50.0, 50.0, 49.5, 29.5),
            ImageSize::new(100, 60),
        );
        let table = RemapTable::build(&output, &source, &Matrix3::identity(), Wrap::None);
        let img = pattern(120, 80, 3);
        let mapping = ImageMapping::Single(&table);
        assert_eq!(mapping.sources(), 1);
        assert_eq!(mapping.size(), ImageSize::new(100, 60));
        let mapped = mapping.apply(&[&img]);
        assert_eq!(mapped.image.as_raw(), table.apply(&img).as_raw());
        assert_eq!(mapped.gains, [1.0]);
        let (mut inside, mut outside) = (0, 0);
        for v in 0..60 {
            for u in 0..100 {
                let s = mapped.source[v as usize * 100 + u as usize];
                assert_eq!(s == 0, table.is_inside(u, v), "pixel ({u}, {v})");
                assert_eq!(mapping.covers(u, v), table.is_inside(u, v));
                if s == 0 {
                    inside += 1
                } else {
                    assert_eq!(s, NO_SOURCE);
                    outside += 1
                }
            }
        }
        // the wider output sees beyond the source: both kinds of pixel occur
        assert!(
            inside > 0 && outside > 0,
            "{inside} inside, {outside} outside"
        );
        let c = PngCompression::default();
        assert_eq!(
            mapping.encode(&[&img], c),
            png::encode_rgb8(&mapped.image, c)
        );
    }

    #[test]
    fn a_stitched_camera_gives_only_the_pixels_its_image_wholly_covers() {
        // a panorama coarser than the lens (25.5 px/rad against 60): every pixel is
        // supersampled, so those along the image's edges have taps beyond it, which the
        // table counts as black
        let lens = Perspective::new(
            Intrinsics::new(60.0, 60.0, 49.5, 39.5),
            ImageSize::new(100, 80),
        );
        let f = 160.0 / (2.0 * std::f64::consts::PI);
        let output = Equirect::new(Intrinsics::new(f, f, 79.5, 39.5), ImageSize::new(160, 80));
        let camera = StitchCamera {
            model: &lens,
            rotation: Matrix3::identity(),
            translation: Vector3::zeros(),
            max_theta: None,
        };
        let options = StitchOptions {
            even_exposure: false,
            ..StitchOptions::default()
        };
        let stitch = Stitch::build(&output, &Vector3::zeros(), &[camera], options);
        let grey = [200, 180, 160];
        let mut flat = RgbImage::new(100, 80);
        for y in 0..80 {
            for x in 0..100 {
                flat.put_pixel(x, y, grey);
            }
        }
        let stitched = ImageMapping::Stitch(&stitch).apply(&[&flat]);
        let table = RemapTable::build(&output, &lens, &Matrix3::identity(), Wrap::None);
        let alone = table.apply(&flat);
        let (mut covered, mut darkened) = (0, 0);
        for v in 0..80 {
            for u in 0..160 {
                if stitched.source[v as usize * 160 + u as usize] == 0 {
                    // an edge pixel darkened by the black beyond the image would be a seam
                    assert_eq!(stitched.image.pixel(u, v), grey, "pixel ({u}, {v})");
                    covered += 1;
                }
                let p = alone.pixel(u, v);
                darkened += usize::from(p != grey && p != [0, 0, 0]);
            }
        }
        // the case occurs: the table alone has partly covered, darkened pixels
        assert!(
            covered > 800 && darkened > 20,
            "{covered} covered, {darkened} darkened"
        );
    }

    #[test]
    fn several_sources_are_the_stitch_and_cover_where_a_camera_weighs() {
        let lens = Perspective::new(
            Intrinsics::new(60.0, 60.0, 49.5, 39.5),
            ImageSize::new(100, 80),
        );
        let turn = |deg: f64| *Rotation3::from_euler_angles(0.0, deg.to_radians(), 0.0).matrix();
        let cameras = [
            StitchCamera {
                model: &lens,
                rotation: turn(-40.0),
                translation: Vector3::zeros(),
                max_theta: None,
            },
            StitchCamera {
                model: &lens,
                rotation: turn(40.0),
                translation: Vector3::new(0.2, 0.0, 0.0),
                max_theta: None,
            },
        ];
        let f = 160.0 / (2.0 * std::f64::consts::PI);
        let output = Equirect::new(Intrinsics::new(f, f, 80.0, 40.0), ImageSize::new(160, 80));
        let stitch = Stitch::build(
            &output,
            &Vector3::zeros(),
            &cameras,
            StitchOptions::default(),
        );
        let (a, b) = (pattern(100, 80, 1), pattern(100, 80, 90));
        let mapping = ImageMapping::Stitch(&stitch);
        assert_eq!(mapping.sources(), 2);
        let mapped = mapping.apply(&[&a, &b]);
        let direct = stitch.apply(&[&a, &b]);
        assert_eq!(mapped.image.as_raw(), direct.image.as_raw());
        assert_eq!(mapped.source, direct.source);
        let mut seen = [0usize; 3];
        for v in 0..80 {
            for u in 0..160 {
                let s = mapped.source[v * 160 + u];
                assert_eq!(
                    mapping.covers(u as u32, v as u32),
                    s != NO_SOURCE,
                    "pixel ({u}, {v})"
                );
                seen[usize::from(s).min(2)] += 1;
            }
        }
        // both cameras give pixels, and the back of the panorama has none
        assert!(seen.iter().all(|&n| n > 0), "{seen:?}");
        let c = PngCompression::default();
        assert_eq!(
            mapping.encode(&[&a, &b], c),
            png::encode_rgb8(&direct.image, c)
        );
    }
}
