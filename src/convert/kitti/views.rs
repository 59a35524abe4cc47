//! [`Views`]: the output views of a frame: the output camera and remap table of each source
//! camera, built once and shared by every frame with that calibration (cached as
//! [`CameraMapping`]s), or drawn per frame for `--augment` (redrawn until a view holds enough
//! objects).

use super::KittiJob;
use crate::camera::{CameraModel, ImageSize, Intrinsics, OutputCamera, Perspective};
use crate::convert::augment_draw::draw_view;
use crate::error::{Error, Result};
use crate::geometry::augment::{view_id, Augment, View};
use crate::kitti::Cam;
use crate::kitti::Split;
use crate::run::OnceMap;
use crate::warp::{Footprint, ImageMapping, RemapTable, LENS_TAPS_BELOW, TAPS_BELOW};
use nalgebra::{Matrix3, Vector3};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

/// The output camera and remap table of one source camera.
#[derive(Clone)]
pub(super) struct CameraMapping {
    pub(super) output: Arc<dyn OutputCamera>,
    pub(super) table: Arc<RemapTable>,
}

impl CameraMapping {
    /// The output camera's pixels from its one source camera.
    pub(super) fn image(&self) -> ImageMapping<'_> {
        ImageMapping::Single(&self.table)
    }
}

/// A source camera: its intrinsics' bits and image size.
type CameraMappingKey = ([u64; 4], ImageSize);

/// The output views of a run's frames: the mappings shared by source camera, and the count of
/// augmented views that hold fewer objects than asked.
pub(super) struct Views<'a> {
    job: &'a KittiJob,
    mappings: OnceMap<CameraMappingKey, std::result::Result<CameraMapping, String>>,
    thin_views: AtomicUsize,
}

/// One output view of a camera.
pub(super) struct OutputView {
    /// The output frame id (the frame's own, or an augmented view's).
    pub(super) id: String,
    pub(super) mapping: CameraMapping,
    /// How an augmented view was drawn; None: the whole frame.
    pub(super) view: Option<View>,
}

impl<'a> Views<'a> {
    pub(super) fn new(job: &'a KittiJob) -> Self {
        Views {
            job,
            mappings: OnceMap::default(),
            thin_views: AtomicUsize::new(0),
        }
    }

    /// Distinct (source camera → output camera) mappings built so far.
    pub(super) fn tables_built(&self) -> usize {
        self.mappings.len()
    }

    /// The shared mapping of a source camera (`calib_path` names its calibration in errors).
    pub(super) fn mapping(
        &self,
        calib_path: &Path,
        k: Intrinsics,
        size: ImageSize,
    ) -> Result<CameraMapping> {
        self.mappings
            .get_or_build(&(k.key(), size), || self.build_mapping(k, size, false))
            .map_err(|m| Error::file(calib_path, m))
    }

    /// The output camera and table of a source camera, the table built serially (inside the
    /// cache's once-cells) or in `parallel` (ahead of the frames).
    pub(super) fn build_mapping(
        &self,
        k: Intrinsics,
        size: ImageSize,
        parallel: bool,
    ) -> std::result::Result<CameraMapping, String> {
        let source = Perspective::new(k, size);
        let output = self
            .job
            .target
            .camera(k, &source)
            .map_err(|e| e.to_string())?;
        let table = table(output.as_ref(), &source, parallel);
        Ok(CameraMapping {
            output: Arc::from(output),
            table: Arc::new(table),
        })
    }

    /// Stores a mapping built ahead of the frames.
    pub(super) fn insert_mapping(
        &self,
        k: Intrinsics,
        size: ImageSize,
        mapping: std::result::Result<CameraMapping, String>,
    ) {
        self.mappings.insert((k.key(), size), mapping);
    }

    /// The output views of a frame: the frame itself, or its augmented views, drawn as `draw`
    /// says. The last element of each augmented view tells how many objects it holds when
    /// they were counted.
    pub(super) fn of(
        &self,
        split: &Split,
        id: &str,
        calib_path: &Path,
        k: Intrinsics,
        size: ImageSize,
        draw: Draw,
    ) -> Result<Vec<OutputView>> {
        let Some(aug) = &self.job.augment else {
            return Ok(vec![OutputView {
                id: id.to_owned(),
                mapping: self.mapping(calib_path, k, size)?,
                view: None,
            }]);
        };
        let source = Perspective::new(k, size);
        let canvas = self
            .job
            .target
            .camera(k, &source)
            .map_err(|e| Error::file(calib_path, e.to_string()))?;
        let view_camera = |view: &View| -> Result<Box<dyn OutputCamera>> {
            let (kv, sv) = Augment::view_camera(view, canvas.intrinsics(), canvas.size());
            canvas
                .with_intrinsics(kv, sv)
                .map_err(|e| Error::file(calib_path, e))
        };
        (0..aug.count)
            .map(|i| {
                let view_id = view_id(id, aug.count, i).ok_or_else(|| {
                    Error::file(
                        &split.image_path(Cam::C2, id),
                        "--augment needs numeric frame ids (e.g. 000123)",
                    )
                })?;
                let (view, output) =
                    self.draw(aug, (split, id), i, canvas.size(), &view_camera, draw)?;
                // Every view has its own camera, so its table is not shared.
                let table = table(output.as_ref(), &source, false);
                let mapping = CameraMapping {
                    output: Arc::from(output),
                    table: Arc::new(table),
                };
                Ok(OutputView {
                    id: view_id,
                    mapping,
                    view: Some(view),
                })
            })
            .collect()
    }

    /// View `i` of frame `id` (on a canvas of `size`) and its camera, drawn as `draw` says.
    fn draw(
        &self,
        aug: &Augment,
        (split, id): (&Split, &str),
        i: u32,
        size: ImageSize,
        view_camera: &dyn Fn(&View) -> Result<Box<dyn OutputCamera>>,
        draw: Draw,
    ) -> Result<(View, Box<dyn OutputCamera>)> {
        Ok(match draw {
            Draw::As(attempts) => {
                let view = aug.view(&split.name, id, i, attempts[i as usize], size);
                (view, view_camera(&view)?)
            }
            Draw::First => {
                let drawn = draw_view(aug, (&split.name, id), i, size, view_camera, None)?;
                (drawn.view, drawn.camera)
            }
            Draw::Fewest(objects) => {
                let count =
                    |output: &dyn OutputCamera| Ok(objects(output as &dyn CameraModel) as usize);
                let drawn = draw_view(aug, (&split.name, id), i, size, view_camera, Some(&count))?;
                // (counted with no minimum asked too: views holding no object)
                if drawn
                    .objects
                    .is_some_and(|n| n < aug.min_objects.max(1) as usize)
                {
                    self.thin_views.fetch_add(1, Ordering::Relaxed);
                }
                (drawn.view, drawn.camera)
            }
        })
    }

    /// Augmented views of labelled frames holding fewer objects than asked (or none, when no
    /// minimum was asked).
    pub(super) fn thin_views(&self) -> usize {
        self.thin_views.load(Ordering::Relaxed)
    }
}

/// The remap table of `output` from `source`: a tap per source pixel below [`TAPS_BELOW`]
/// ([`LENS_TAPS_BELOW`] for a lens) source pixels a pixel, the source's pyramid above. For a
/// fisheye output only the part of the lens image the source can reach is mapped (the same
/// table, without the lens inversions of the pixels no source ray reaches, most of a wide
/// lens's image).
fn table(output: &dyn OutputCamera, source: &Perspective, parallel: bool) -> RemapTable {
    let identity = Matrix3::identity();
    let Some(lens) = output.as_fisheye() else {
        return RemapTable::build_pyramid_above(output, source, &identity, TAPS_BELOW, parallel);
    };
    // a lens sees no further than a cap around its backward axis
    let blind = lens.rect_from_camera * -Vector3::z();
    let seen = Footprint::new(output, source, &identity, &blind);
    RemapTable::build_pyramid_above_within(
        output,
        source,
        &identity,
        LENS_TAPS_BELOW,
        seen.as_ref(),
        parallel,
    )
}

/// How a camera's augmented views are drawn.
#[derive(Clone, Copy)]
pub(super) enum Draw<'a> {
    /// Redrawn until they hold enough objects, counted by the function (camera 2).
    Fewest(&'a dyn Fn(&dyn CameraModel) -> u32),
    /// With the draws camera 2's views took (camera 3 follows camera 2).
    As(&'a [u32]),
    /// The first draw of each view.
    First,
}
