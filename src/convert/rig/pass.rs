//! One frame of a rig into one output camera: the camera, the stitch of the chosen rig cameras
//! (docs/kitti360.md, "Stitching"), the source map, the labels and the depth map.
//!
//! The output camera's axes are the frame's reference frame, its centre C2 the mean of the
//! chosen cameras' centres unless given. Its canvas and default scale come from the *first*
//! chosen camera seen in the reference frame's axes (`OutputSpec` as for KITTI, the canvas
//! `Full360` for a panorama of several cameras); a fisheye target is the given lens, turned by
//! its rotation relative to the reference frame. The rig moves in the reference frame from
//! frame to frame (KITTI-360's level frame follows gravity, not the vehicle), so the stitch's
//! tables are built per frame, unless the geometry repeats exactly (`stitch_cache.rs`).

use super::coverage::Coverage;
use super::frame_cache::FrameCache;
use super::objects::{label_objects, DropReason, ObjectOutcome, ObjectRule, PlacedObject};
use super::scene_depth::{at_proxy, distance_map, frame_stitch_in, StitchMode};
use crate::camera::{CameraModel, ImageSize, OutputCamera, ProjectionReject};
use crate::convert::view_depth::{view_depth, DepthDomain, ViewLidar};
use crate::error::{Error, Result};
use crate::geometry::Target;
use crate::image::RgbImage;
use crate::reproject::depth::{DepthMap, OcclusionFilter};
use crate::run::manifest::LidarRecord;
use crate::source::{Frame, RigCamera, SourceBox};
use crate::style::StyleModel;

/// The dataset's own verdict on a box before any geometry: None to go on, or why it is
/// dropped (its class, or the dataset's count of the sensor returns in it).
pub type ClassFilter<'a> = &'a (dyn Fn(&SourceBox) -> Option<DropReason> + Sync);
use crate::warp::{
    EgoMask, ImageMapping, Stitch, StitchCamera, StitchOptions, FALLBACK_SOURCE, FAR_SOURCE,
    NO_SOURCE,
};
use nalgebra::{Matrix3, Point2, Vector3};
use std::sync::Arc;

pub use crate::source::CameraInfo;

/// How a frame is converted.
#[derive(Debug, Clone)]
pub struct RigOptions {
    /// Indices into the frame's rig of the cameras used, in order.
    pub cameras: Vec<usize>,
    /// Proxy distance, blend width, exposure gains.
    pub stitch: StitchOptions,
    /// Depth-guided (when the frame has a scan) or at the proxy distance.
    pub stitch_mode: StitchMode,
    /// Keep the depth-guided stitch's distance map ([`RigFrame::distances`]).
    pub stitch_depth: bool,
    /// The frame's boxes that are labelled (and listed with their outcome); the others are
    /// only scenery for the depth-guided stitch. None: every box.
    pub listed: Option<fn(&SourceBox) -> bool>,
    /// The output centre C2 in the reference frame (default: the mean of the cameras').
    pub centre: Option<Vector3<f64>>,
    /// Which objects are written.
    pub objects: ObjectRule,
    /// Write a depth map: with the occlusion filter, or without (None inside).
    pub depth: Option<Option<OcclusionFilter>>,
    /// Ego masks by rig index (None, or a shorter list, for cameras without one).
    pub ego_masks: Vec<Option<Arc<EgoMask>>>,
    /// The style model each chosen camera's image goes through before the stitch.
    pub style: Option<Arc<StyleModel>>,
}

/// A converted frame.
pub struct RigFrame {
    /// The output camera (axes: the reference frame's).
    pub camera: Box<dyn OutputCamera>,
    /// Its centre C2 in the reference frame.
    pub centre: Vector3<f64>,
    /// The stitched image.
    pub image: RgbImage,
    /// Per pixel, the rig index of the camera of largest weight, 255 for none.
    pub source: Vec<u8>,
    /// Each used camera's exposure gain.
    pub gains: Vec<f64>,
    /// The written objects, placed in the output camera (the dataset's writer formats them).
    pub labels: Vec<PlacedObject>,
    /// Every object's outcome.
    pub objects: Vec<ObjectOutcome>,
    /// The depth map (none where no camera gives the pixel) and its manifest record.
    pub depth: Option<(DepthMap, LidarRecord)>,
    /// How the frame was stitched.
    pub stitch_mode: StitchMode,
    /// With `stitch_depth`, the distance each pixel was stitched at (depth-guided only).
    pub distances: Option<DepthMap>,
}

impl RigFrame {
    /// Whether a `source` value (`source_2`) marks a trustworthy colour: a camera passed the
    /// occlusion test there (below 64; the far fill's camera + 64, the fallback's camera + 128
    /// and the uncovered 255 are not). In a fixed stitch, every covered pixel.
    pub fn trusted(source: u8) -> bool {
        source < FAR_SOURCE
    }

    /// The `--mask` image (`mask_2/`): a 1-bit PNG, white where [`RigFrame::trusted`], as
    /// `kitti --mask` writes its own.
    pub fn encode_mask(&self) -> Vec<u8> {
        let size = self.camera.size();
        let width = size.width as usize;
        crate::codec::png::encode_mask(size.width, size.height, |u, v| {
            Self::trusted(self.source[v as usize * width + u as usize])
        })
    }
}

/// A rig camera's model with bearings in the reference frame's axes.
#[derive(Debug)]
struct InReference<'a> {
    model: &'a dyn CameraModel,
    reference_from_camera: Matrix3<f64>,
    camera_from_reference: Matrix3<f64>,
}

impl CameraModel for InReference<'_> {
    fn project(&self, d: &Vector3<f64>) -> std::result::Result<Point2<f64>, ProjectionReject> {
        self.model.project_point(&(self.camera_from_reference * d))
    }

    fn unproject(&self, p: &Point2<f64>) -> std::result::Result<Vector3<f64>, ProjectionReject> {
        Ok((self.reference_from_camera * self.model.unproject(p)?).normalize())
    }

    fn distance(&self, p: &Vector3<f64>) -> f64 {
        p.norm()
    }

    fn size(&self) -> ImageSize {
        self.model.size()
    }
}

/// The output camera of `frame` for `target`, from its first chosen camera (a
/// [`crate::geometry::Canvas::Band`] spans every chosen camera's field of view).
pub fn output_camera(
    frame: &Frame,
    info: &[CameraInfo],
    target: &Target,
    cameras: &[usize],
) -> Result<Box<dyn OutputCamera>> {
    let in_reference = |k: usize| -> Result<InReference> {
        let camera = &frame.rig[k];
        let r = camera.reference_from_camera.rotation;
        Ok(InReference {
            model: camera.model.as_ref(),
            reference_from_camera: r,
            camera_from_reference: r
                .try_inverse()
                .ok_or_else(|| Error::Setup(format!("{}: singular pose", camera.name)))?,
        })
    };
    let Some(&first) = cameras.first() else {
        return Err(Error::Setup("no camera chosen".into()));
    };
    let source = in_reference(first)?;
    let others = cameras[1..]
        .iter()
        .map(|&k| in_reference(k))
        .collect::<Result<Vec<_>>>()?;
    let others: Vec<&dyn CameraModel> = others.iter().map(|o| o as &dyn CameraModel).collect();
    target.camera_over(info[first].focal, &source, &others)
}

/// Converts `frame` (its rig described by `info`, one per rig camera) into `target`, writing
/// the objects whose class `keep_class` accepts.
pub fn convert_frame(
    frame: &Frame,
    info: &[CameraInfo],
    target: &Target,
    options: &RigOptions,
    keep_class: ClassFilter,
) -> Result<RigFrame> {
    chosen_cameras(frame, options)?;
    let camera = output_camera(frame, info, target, &options.cameras)?;
    let images = read_images(frame, options)?;
    convert_into(frame, info, camera, &images, options, keep_class)
}

/// The output centre C2: the given one, else the mean of the chosen cameras' centres.
fn output_centre(chosen: &[&RigCamera], options: &RigOptions) -> Vector3<f64> {
    options.centre.unwrap_or_else(|| {
        chosen.iter().map(|c| c.centre()).sum::<Vector3<f64>>() / chosen.len() as f64
    })
}

/// How many objects `camera` would hold as labels (what an augmented view's draw counts).
pub fn count_objects(
    (frame, info): (&Frame, &[CameraInfo]),
    camera: &dyn OutputCamera,
    options: &RigOptions,
    keep_class: ClassFilter,
) -> Result<usize> {
    let chosen = chosen_cameras(frame, options)?;
    let centre = output_centre(&chosen, options);
    let (_, outcomes) = label_objects(
        &listed_objects(frame, options).0,
        &frame.lidar,
        (&centre, camera),
        &Coverage::of(frame, info, &options.cameras)?,
        &options.objects,
        keep_class,
    );
    // Objects only: the DontCare regions of barely visible ones do not count.
    Ok(outcomes.iter().filter(|o| o.dropped.is_none()).count())
}

/// The frame's boxes that are labelled ([`RigOptions::listed`]), and the index of each in the
/// frame's `objects` (where [`PlacedObject::index`] points).
fn listed_objects(frame: &Frame, options: &RigOptions) -> (Vec<SourceBox>, Vec<usize>) {
    frame
        .objects
        .iter()
        .enumerate()
        .filter(|(_, b)| options.listed.is_none_or(|listed| listed(b)))
        .map(|(i, b)| (b.clone(), i))
        .unzip()
}

/// The chosen cameras of the frame's rig, in the options' order.
fn chosen_cameras<'f>(frame: &'f Frame, options: &RigOptions) -> Result<Vec<&'f RigCamera>> {
    options
        .cameras
        .iter()
        .map(|&i| {
            frame.rig.get(i).ok_or_else(|| {
                Error::Setup(format!(
                    "the rig has no camera {i} ({} cameras)",
                    frame.rig.len()
                ))
            })
        })
        .collect()
}

/// The images of the chosen cameras, decoded, checked against their calibration's size and,
/// with a style model, styled (each image on its own, so a pixel's style does not depend on
/// the other cameras).
pub fn read_images(frame: &Frame, options: &RigOptions) -> Result<Vec<RgbImage>> {
    Ok(read_images_hashed(frame, options)?.0)
}

/// [`read_images`], with the blake3 (hex) of each image file's bytes as they were read.
pub fn read_images_hashed(
    frame: &Frame,
    options: &RigOptions,
) -> Result<(Vec<RgbImage>, Vec<String>)> {
    let chosen = chosen_cameras(frame, options)?;
    let mut images = Vec::with_capacity(chosen.len());
    let mut hashes = Vec::with_capacity(chosen.len());
    for c in &chosen {
        let bytes = crate::fs::read_file(&c.image)?;
        hashes.push(crate::fs::hash_hex(&bytes));
        let image = crate::codec::decode_rgb8(&bytes, &c.image)?;
        let want = c.model.size();
        if (image.width(), image.height()) != (want.width, want.height) {
            return Err(Error::file(
                &c.image,
                format!(
                    "the image is {}x{}, the calibration of {} says {}x{}",
                    image.width(),
                    image.height(),
                    c.name,
                    want.width,
                    want.height
                ),
            ));
        }
        let image = match &options.style {
            Some(model) => model
                .stylize(&image)
                .map_err(|e| Error::file(&c.image, format!("style pass: {e}")))?,
            None => image,
        };
        images.push(image);
    }
    Ok((images, hashes))
}

/// [`convert_frame`] into a given output `camera` (its axes the reference frame's), from the
/// chosen cameras' `images` as [`read_images`] gives them.
pub fn convert_into(
    frame: &Frame,
    info: &[CameraInfo],
    camera: Box<dyn OutputCamera>,
    images: &[RgbImage],
    options: &RigOptions,
    keep_class: ClassFilter,
) -> Result<RigFrame> {
    let cache = FrameCache::default();
    convert_view((frame, &cache), info, camera, images, options, keep_class)
}

/// [`convert_into`] for one of a frame's views, with what its views share in `cache`.
pub(super) fn convert_view(
    (frame, cache): (&Frame, &FrameCache),
    info: &[CameraInfo],
    camera: Box<dyn OutputCamera>,
    images: &[RgbImage],
    options: &RigOptions,
    keep_class: ClassFilter,
) -> Result<RigFrame> {
    let chosen = chosen_cameras(frame, options)?;
    if images.len() != chosen.len() {
        return Err(Error::Setup(format!(
            "{} images for {} cameras",
            images.len(),
            chosen.len()
        )));
    }
    let RigStitch {
        stitch,
        mode: stitch_mode,
        centre,
    } = rig_stitch_in((frame, cache), info, camera.as_ref(), options)?;
    let distances = options
        .stitch_depth
        .then(|| distance_map(&stitch))
        .flatten();
    let refs: Vec<&RgbImage> = images.iter().collect();
    let stitched = ImageMapping::Stitch(&stitch).apply(&refs);
    let source: Vec<u8> = stitched
        .source
        .iter()
        .map(|&s| {
            let rule = s & (FALLBACK_SOURCE | FAR_SOURCE);
            match options
                .cameras
                .get((s & !(FALLBACK_SOURCE | FAR_SOURCE)) as usize)
            {
                Some(&i) if s != NO_SOURCE => u8::try_from(i).map_or(254, |i| i | rule),
                _ => NO_SOURCE,
            }
        })
        .collect();
    let (listed, frame_index) = listed_objects(frame, options);
    let (mut labels, objects) = label_objects(
        &listed,
        &frame.lidar,
        (&centre, camera.as_ref()),
        &Coverage::of(frame, info, &options.cameras)?,
        &options.objects,
        keep_class,
    );
    for placed in &mut labels {
        placed.index = frame_index[placed.index];
    }
    let depth = options.depth.map(|filter| {
        let lidar = ViewLidar {
            points: cache.points(frame),
            non_finite: 0,
            filter: filter.as_ref(),
        };
        view_depth(
            &lidar,
            &centre,
            camera.as_ref(),
            DepthDomain::Coverage(&source),
        )
    });
    Ok(RigFrame {
        camera,
        centre,
        image: stitched.image,
        source,
        gains: stitched.gains,
        labels,
        objects,
        depth,
        stitch_mode,
        distances,
    })
}

/// A frame's stitch as [`convert_into`] builds it, with the mode it was built in and the output
/// centre C2.
pub struct RigStitch {
    /// The stitch (shared with the run's other frames where their geometry is the same).
    pub stitch: Arc<Stitch>,
    /// Depth-guided, or at the proxy distance.
    pub mode: StitchMode,
    /// C2 in the reference frame.
    pub centre: Vector3<f64>,
}

/// The stitch of `frame`'s chosen cameras into `camera` (its axes the reference frame's).
pub fn rig_stitch(
    frame: &Frame,
    info: &[CameraInfo],
    camera: &dyn CameraModel,
    options: &RigOptions,
) -> Result<RigStitch> {
    rig_stitch_in((frame, &FrameCache::default()), info, camera, options)
}

/// [`rig_stitch`] with the frame's depth-guided scene built once in `cache` (a frame's views
/// share it), and a fixed stitch taken from the run's kept ones where its geometry repeats.
fn rig_stitch_in(
    (frame, cache): (&Frame, &FrameCache),
    info: &[CameraInfo],
    camera: &dyn CameraModel,
    options: &RigOptions,
) -> Result<RigStitch> {
    let chosen = chosen_cameras(frame, options)?;
    let centre = output_centre(&chosen, options);
    let mut inverses = Vec::with_capacity(chosen.len());
    for c in &chosen {
        inverses.push(
            c.reference_from_camera
                .inverse()
                .ok_or_else(|| Error::file(&c.image, format!("{}: singular pose", c.name)))?,
        );
    }
    let cameras: Vec<StitchCamera> = chosen
        .iter()
        .zip(&inverses)
        .zip(&options.cameras)
        .map(|((c, inv), &i)| StitchCamera {
            model: c.model.as_ref(),
            rotation: inv.rotation,
            translation: inv.translation,
            max_theta: info[i].max_theta,
        })
        .collect();
    let masks: Vec<Option<&EgoMask>> = options
        .cameras
        .iter()
        .map(|&i| options.ego_masks.get(i).and_then(|m| m.as_deref()))
        .collect();
    let fixed = at_proxy(frame, cameras.len(), options.stitch_mode);
    if let Some(kept) = cache.stitches.as_ref().filter(|_| fixed) {
        return Ok(RigStitch {
            stitch: kept.fixed(camera, &centre, &cameras, &masks, options.stitch)?,
            mode: StitchMode::Fixed,
            centre,
        });
    }
    let eyes = chosen.iter().map(|c| c.centre()).collect();
    let (stitch, stitch_mode) = frame_stitch_in(
        (frame, &cache.scene),
        camera,
        &centre,
        (&cameras, eyes),
        &masks,
        options.stitch,
        options.stitch_mode,
    )?;
    Ok(RigStitch {
        stitch: Arc::new(stitch),
        mode: stitch_mode,
        centre,
    })
}
