//! A rig conversion's output canvas and scale from its flags: a panorama of several cameras is,
//! by default, [`DEFAULT_PANO_WIDTH`] pixels for 360° over the band of elevations its cameras
//! cover (nuScenes' six cameras leave 81 % of a whole equirect sphere black); `--full-360`
//! asks for the whole sphere, `--size` for an explicit canvas, and an explicit scale alone
//! keeps the whole sphere as before.

use crate::camera::Projection;
pub use crate::convert::canvas_flags::CanvasFlags;
use crate::error::{Error, Result};
use crate::geometry::{Canvas, OutputSpec, Scale};
use std::path::{Path, PathBuf};

/// The width of a rig panorama's 360° when no scale is given: a size trainers take.
pub const DEFAULT_PANO_WIDTH: u32 = 2048;

/// The output spec of `projection` for a rig of `cameras` chosen cameras: one camera, or a
/// perspective view, is converted as `kitti` converts one (the first camera's scale, its
/// tight field of view unless `--full-360` or `--size`); a panorama of several cameras takes
/// [`Canvas::Band`] at [`DEFAULT_PANO_WIDTH`] when no flag says otherwise.
pub fn rig_output_spec(
    projection: Projection,
    cameras: usize,
    flags: &CanvasFlags,
) -> Result<OutputSpec> {
    if flags.full_360 && flags.size.is_some() {
        return Err(Error::Setup(
            "--full-360 and --size exclude each other".into(),
        ));
    }
    let given = flags.scale()?;
    let panorama = cameras > 1 && projection != Projection::Perspective;
    let (scale, canvas) = match (flags.full_360, flags.size) {
        (true, _) => (given, Canvas::Full360),
        (false, Some(s)) => (given, Canvas::Size(s)),
        (false, None) if !panorama => (given, Canvas::Tight),
        (false, None) if given != Scale::SourceFocal => (given, Canvas::Full360),
        (false, None) => (Scale::PanoWidth(DEFAULT_PANO_WIDTH), Canvas::Band),
    };
    Ok(OutputSpec {
        projection,
        scale,
        canvas,
        crop: flags.crop,
        resize: flags.resize,
    })
}

/// Which of a rig output's first written frame its cameras cover, from its `source_2`.
#[derive(Debug, Clone, PartialEq)]
pub struct Coverage {
    /// The source map read (`OUT/training/source_2/ID.png`).
    pub file: PathBuf,
    /// Its width and height.
    pub size: (u32, u32),
    /// The share of its pixels that no camera covers (`source_2` =
    /// [`crate::warp::NO_SOURCE`]).
    pub uncovered: f64,
    /// The first and last rows with a camera's pixel (None: none has one); the rows above
    /// and below look beyond every camera (a whole sphere's poles).
    pub rows: Option<(u32, u32)>,
    /// The share of the pixels of those rows and the rows between that no camera covers.
    pub uncovered_within: f64,
}

/// The coverage of the first written frame of the rig output `output`; None when it has none
/// to read.
pub fn coverage(output: &Path) -> Option<Coverage> {
    let dir = output.join(super::SPLIT).join("source_2");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&dir)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    names.sort();
    let file = names.into_iter().next()?;
    let bytes = std::fs::read(&file).ok()?;
    let image = crate::codec::png::decode_rgb8(&bytes, &file).ok()?;
    let (w, h) = (image.width(), image.height());
    if w == 0 {
        return None;
    }
    // uncovered pixels per row
    let per_row: Vec<usize> = (image.as_raw().chunks_exact(3 * w as usize))
        .map(|row| {
            let pixels = row.chunks_exact(3);
            pixels.filter(|p| p[0] == crate::warp::NO_SOURCE).count()
        })
        .collect();
    let seen = |n: &usize| *n < w as usize;
    let rows = per_row
        .iter()
        .position(seen)
        .zip(per_row.iter().rposition(seen));
    let uncovered = per_row.iter().sum::<usize>();
    let within = rows.map_or(0, |(a, b)| per_row[a..=b].iter().sum::<usize>());
    let band_pixels = rows.map_or(0, |(a, b)| (b - a + 1) * w as usize);
    Some(Coverage {
        file,
        size: (w, h),
        uncovered: uncovered as f64 / (w as usize * h as usize).max(1) as f64,
        rows: rows.map(|(a, b)| (a as u32, b as u32)),
        uncovered_within: within as f64 / band_pixels.max(1) as f64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panorama_without_flags_is_the_band_and_an_explicit_scale_the_sphere() {
        let eq = Projection::Equirect;
        let spec = rig_output_spec(eq, 6, &CanvasFlags::default()).unwrap();
        assert_eq!(spec.canvas, Canvas::Band);
        assert_eq!(spec.scale, Scale::PanoWidth(DEFAULT_PANO_WIDTH));
        let width = CanvasFlags {
            pano_width: Some(1024),
            ..Default::default()
        };
        let spec = rig_output_spec(eq, 6, &width).unwrap();
        assert_eq!(
            (spec.scale, spec.canvas),
            (Scale::PanoWidth(1024), Canvas::Full360)
        );
        let one = rig_output_spec(eq, 1, &CanvasFlags::default()).unwrap();
        assert_eq!((one.scale, one.canvas), (Scale::SourceFocal, Canvas::Tight));
        let full = CanvasFlags {
            full_360: true,
            ..Default::default()
        };
        let spec = rig_output_spec(eq, 6, &full).unwrap();
        assert_eq!(
            (spec.scale, spec.canvas),
            (Scale::SourceFocal, Canvas::Full360)
        );
    }
}
