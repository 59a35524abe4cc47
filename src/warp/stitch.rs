//! Stitching: N source cameras with their own optical centres remapped into one output camera.
//!
//! The model (every pixel can be recomputed from it):
//!
//! 1. An output pixel's ray leaves the output centre C with unit direction d (the output
//!    camera's `unproject`, in the reference frame's axes). The scene along it is taken to lie
//!    at the *proxy distance* s: the point X = C + s·d.
//! 2. Camera i sees X at q_i = camera_from_reference_i(X) and samples it at its pixel
//!    p_i = project_i(q_i). The output pixel's value from camera i is camera i's image resampled
//!    there by a [`RemapTable`] (bilinear taps, supersampled where the output is coarser than
//!    the source, exact integer weights), built through the same mapping. Where a pixel spans
//!    2 or more source pixels along both axes it takes one bilinear tap (more along an
//!    anisotropic footprint's longer axis) of the source's pyramid instead, at the level where
//!    it spans 0.75 to 1.5 level pixels ([`RemapTable::build_pyramid_above`]); in a
//!    depth-guided stitch only where the scene's distances at the pixel and its eight
//!    neighbours lie on one surface (a pixel across a depth edge measures a wide footprint
//!    spanning two surfaces, and keeps its taps, each through its own surface).
//! 3. Camera i's weight is w_i = S(min(1, m_i / b)), with S(t) = t²(3 − 2t) (smoothstep), b the
//!    blend width (radians) and m_i the angular margin of q_i inside the camera's view: the
//!    smaller of (a) its field of view's margin θ_max,i − θ(q_i), θ the angle from the optical
//!    axis (for a lens with a field of view), and (b) the distance of p_i to the nearest image
//!    edge (pixels; the edges at −0.5 and size − 0.5) divided by the local scale at p_i (pixels
//!    per radian: the larger of the image displacements of q_i turned by 1e-4 rad about two
//!    axes perpendicular to it). m_i ≤ 0, or no image of q_i, gives w_i = 0; so does a sample
//!    that lies only partly inside the image (a supersampled pixel at its edge, whose taps
//!    beyond the edge count as black in the table): a camera contributes where its image covers
//!    the pixel's whole footprint.
//! 4. The output value is Σ w_i·g_i·v_i / Σ w_i per channel, rounded to the nearest integer
//!    (ties away from zero), clamped to 0..=255, black where Σ w_i = 0. The source map names the
//!    camera of largest weight (the first on a tie), 255 where none.
//! 5. The exposure gains g_i are 1 when exposure evening is off. Otherwise, per frame: over the
//!    output pixels where cameras i and j both have w > 0 (N_ij of them), m_ij is the mean of
//!    camera i's resampled values there (all three channels, 0..=255; sums kept as integers).
//!    g minimises Σ_{i<j} N_ij (g_i·m_ij − g_j·m_ji)² + μ Σ_i (g_i − 1)², μ = 1e-6·Σ_{i<j} N_ij
//!    (a prior that only fixes the common scale the first term leaves free, and cameras
//!    without overlaps), solved exactly as its normal equations; then every g_i is divided by
//!    g_0, so the first camera keeps its exposure. Gains that are not finite and positive, or
//!    a singular system, give g_i = 1.
//! 6. With an ego mask for camera i ([`EgoMask`], `Stitch::build_masked`), w_i = 0 wherever
//!    camera i's sample would touch its mask: where a masked pixel centre lies within
//!    1 + ρ/2 pixels of p_i in x and in y, ρ the larger distance from p_i to the samples of the
//!    output pixels to the right and below (the footprint a supersampled tap can reach); for a
//!    table that samples the pyramid, within max(1 + ρ/2, 3ρ) where ρ is 1 or more (a level's
//!    bilinear tap reaches 1.5 level pixels, up to 2ρ, and the taps along the longer axis ρ/2
//!    further).
//!
//! When every camera's centre is C (a zero-baseline rig) the proxy distance plays no part and
//! the remap is exact; otherwise objects at the proxy distance are stitched exactly and nearer
//! or farther ones show the parallax between the cameras at the seams.
//!
//! The files: `proxy.rs` the mapping through the proxy point (steps 1 and 2; a pinhole's in
//! lanes, `fixed_proxy.rs`), `weights.rs` the
//! tables and the blend weights with their margins and ego masks (steps 2, 3 and 6), `gains.rs`
//! the exposure gains (step 5), `apply.rs` a frame's blend (step 4), `grid.rs` the depth-guided
//! stitch of pinhole rigs through a distance grid in the output's own pixels.

mod apply;
mod centre_fill;
mod fallback;
mod far_fill;
mod figures;
mod fixed_proxy;
mod gains;
mod grid;
mod guided;
mod guided_lanes;
mod guided_lens;
mod proxy;
mod weights;

pub use fallback::FALLBACK_SOURCE;
pub use far_fill::FAR_SOURCE;
pub use figures::StitchFigures;
pub use grid::{grid_applies, GridBox, GridScene, GroundHit};
pub use guided::StitchDepth;

use super::mask::EgoMask;
use super::table::RemapTable;
use crate::camera::{CameraModel, ImageSize};
use crate::error::{Error, Result};
use crate::image::RgbImage;
use nalgebra::{Matrix3, Vector3};

/// A source camera of a stitch.
#[derive(Debug, Clone, Copy)]
pub struct StitchCamera<'a> {
    /// The camera's model (bearings in its own axes).
    pub model: &'a dyn CameraModel,
    /// camera_from_reference's linear part: a point X of the reference frame is
    /// `rotation · X + translation` in camera coordinates.
    pub rotation: Matrix3<f64>,
    /// camera_from_reference's translation.
    pub translation: Vector3<f64>,
    /// Half the field of view for a lens that has one (its image beyond is not used).
    pub max_theta: Option<f64>,
}

/// The stitch's two parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StitchOptions {
    /// Proxy distance s, metres.
    pub distance: f64,
    /// Blend width b, radians.
    pub blend_width: f64,
    /// Even the exposure of the cameras with per-frame gains (step 5 of the model).
    pub even_exposure: bool,
}

impl Default for StitchOptions {
    /// s = 10 m, b = 5°, exposure evening on.
    fn default() -> Self {
        Self {
            distance: 10.0,
            blend_width: 5f64.to_radians(),
            even_exposure: true,
        }
    }
}

/// Tables and weights of a stitch, built once per output camera and rig, applied per frame.
#[derive(Debug)]
pub struct Stitch {
    size: ImageSize,
    tables: Vec<RemapTable>,
    /// Per camera, per output pixel (row-major): w_i.
    weights: Vec<Vec<f32>>,
    even_exposure: bool,
    /// A depth-guided stitch's distance at each output pixel centre.
    distances: Option<Vec<f64>>,
    /// A depth-guided stitch's pixels filled by the fallback rule ([`FALLBACK_SOURCE`]).
    fallback: Option<Vec<bool>>,
    /// A depth-guided stitch's pixels stitched at the proxy distance ([`FAR_SOURCE`]).
    far: Option<Vec<bool>>,
    /// A depth-guided stitch's pixels no camera weighs whose centre an image holds, in pixel
    /// order (`centre_fill.rs`).
    centre: Vec<centre_fill::CentreSample>,
}

/// One frame's stitch.
#[derive(Debug)]
pub struct Stitched {
    /// The stitched image.
    pub image: RgbImage,
    /// Per output pixel, the camera of largest weight (255 for none).
    pub source: Vec<u8>,
    /// The exposure gain g_i of each camera (all 1 with exposure evening off).
    pub gains: Vec<f64>,
}

impl Stitch {
    /// The stitch of `cameras` into `output` (its bearings in the reference frame's axes,
    /// from `centre`).
    pub fn build(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        options: StitchOptions,
    ) -> Stitch {
        let built = Self::tables_and_weights(output, centre, cameras, &[], options, true, None);
        Stitch::from_parts(output.size(), built, options)
    }

    fn from_parts(
        size: ImageSize,
        built: weights::TablesAndWeights,
        options: StitchOptions,
    ) -> Self {
        Stitch {
            size,
            tables: built.tables,
            weights: built.weights,
            even_exposure: options.even_exposure,
            distances: built.distances,
            fallback: built.fallback,
            far: built.far,
            centre: built.centre,
        }
    }

    /// [`Stitch::build`] with an ego mask per camera (`masks[i]` for `cameras[i]`; None, or a
    /// shorter list, for cameras without one): step 6 of the model. A mask of another size
    /// than its camera's image is an error.
    pub fn build_masked(
        output: &dyn CameraModel,
        centre: &Vector3<f64>,
        cameras: &[StitchCamera],
        masks: &[Option<&EgoMask>],
        options: StitchOptions,
    ) -> Result<Stitch> {
        Self::check_masks(cameras, masks)?;
        let built = Self::tables_and_weights(output, centre, cameras, masks, options, true, None);
        Ok(Stitch::from_parts(output.size(), built, options))
    }

    /// A mask list that fits the cameras: no more masks than cameras, each of its camera's
    /// image size.
    fn check_masks(cameras: &[StitchCamera], masks: &[Option<&EgoMask>]) -> Result<()> {
        if masks.len() > cameras.len() {
            return Err(Error::Setup(format!(
                "{} ego masks for {} cameras",
                masks.len(),
                cameras.len()
            )));
        }
        for (i, (camera, mask)) in cameras.iter().zip(masks).enumerate() {
            if let Some(mask) = mask {
                let (a, b) = (mask.size(), camera.model.size());
                if a != b {
                    return Err(Error::Setup(format!(
                        "camera {i}: an ego mask of {}x{} for an image of {}x{}",
                        a.width, a.height, b.width, b.height
                    )));
                }
            }
        }
        Ok(())
    }

    /// The output image's size.
    pub fn size(&self) -> ImageSize {
        self.size
    }

    /// How many cameras it blends.
    pub fn cameras(&self) -> usize {
        self.tables.len()
    }

    /// Whether a depth-guided stitch's fallback rule filled output pixel (u, v): no camera
    /// was shown to see its point ([`FALLBACK_SOURCE`]).
    pub fn fell_back(&self, u: u32, v: u32) -> bool {
        let i = v as usize * self.size.width as usize + u as usize;
        self.fallback.as_ref().is_some_and(|f| f[i])
    }

    /// Whether a depth-guided stitch's far fill took output pixel (u, v): no camera's image
    /// holds its point at the scene's distance, so it was stitched at the proxy distance
    /// ([`FAR_SOURCE`]).
    pub fn filled_far(&self, u: u32, v: u32) -> bool {
        let i = v as usize * self.size.width as usize + u as usize;
        self.far.as_ref().is_some_and(|f| f[i])
    }

    /// Camera i's weight at output pixel (u, v).
    pub fn weight(&self, i: usize, u: u32, v: u32) -> f32 {
        self.weights[i][v as usize * self.size.width as usize + u as usize]
    }
}
