//! Training-time augmentation: N random scale-and-crop views per frame, each one resampled once
//! from the source with its own camera. Reproducible from the seed whatever the thread count:
//! every draw comes from a hash of (seed, split, frame, view), never from a shared generator.

use crate::camera::{ImageSize, Intrinsics};
use crate::geometry::{crop_intrinsics, resize_intrinsics, Crop};
use serde::{Deserialize, Serialize};

/// `--augment`: random scale-and-crop views of every frame, reproducible from the seed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Augment {
    /// Views per frame.
    pub count: u32,
    /// Seed of every draw (`--seed`); with the split, frame id and view index it fixes a view.
    pub seed: u64,
    /// Scale factors drawn uniformly from [min, max], applied to the output canvas.
    pub scale_range: (f64, f64),
    /// Size of every view.
    pub crop_size: ImageSize,
    /// A view holding fewer objects (DontCare aside) is drawn again, up to [`MAX_ATTEMPTS`]
    /// times. 0: every first draw stands.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub min_objects: u32,
}

/// Draws of one view tried before a view short of objects is kept as it is.
pub const MAX_ATTEMPTS: u32 = 16;

fn is_zero(n: &u32) -> bool {
    *n == 0
}

/// One drawn view: the canvas resized to `scaled`, then the window `crop` of it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// Which view of the frame, from 0 to `count` − 1.
    pub index: u32,
    /// The scale factor drawn from `scale_range`.
    pub scale: f64,
    /// Size of the canvas after scaling, pixels (rounded, at least 1×1).
    pub scaled: ImageSize,
    /// The view's window of the scaled canvas, in its pixels; centred with black margins where the
    /// view is larger than the scaled canvas.
    pub crop: Crop,
    /// Which draw of this view it is (0: the first; more with `min_objects`).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub attempt: u32,
}

/// Uniform numbers in [0, 1) from a keyed hash.
struct Draws {
    bytes: [u8; 64],
    at: usize,
}

impl Draws {
    fn new(seed: u64, split: &str, frame: &str, view: u32, attempt: u32) -> Self {
        let mut h = blake3::Hasher::new();
        h.update(b"panoconv-augment-v1");
        h.update(&seed.to_le_bytes());
        h.update(split.as_bytes());
        h.update(&[0]);
        h.update(frame.as_bytes());
        h.update(&view.to_le_bytes());
        // (the first draw hashes as it always did, so views without redraws do not change)
        if attempt > 0 {
            h.update(&attempt.to_le_bytes());
        }
        let mut bytes = [0u8; 64];
        h.finalize_xof().fill(&mut bytes);
        Self { bytes, at: 0 }
    }

    fn next(&mut self) -> f64 {
        let v = u64::from_le_bytes(
            self.bytes[self.at..self.at + 8]
                .try_into()
                .expect("8 bytes"),
        );
        self.at += 8;
        (v >> 11) as f64 / (1u64 << 53) as f64
    }
}

impl Augment {
    /// Draw `attempt` of the `index`-th view of a frame whose full output canvas is `canvas`.
    pub fn view(
        &self,
        split: &str,
        frame: &str,
        index: u32,
        attempt: u32,
        canvas: ImageSize,
    ) -> View {
        let mut d = Draws::new(self.seed, split, frame, index, attempt);
        let (lo, hi) = self.scale_range;
        let scale = lo + (hi - lo) * d.next();
        let scaled = ImageSize::new(
            ((canvas.width as f64 * scale).round() as u32).max(1),
            ((canvas.height as f64 * scale).round() as u32).max(1),
        );
        // The window lies inside the scaled canvas where it fits, else centred with black margins.
        let place = |extent: u32, window: u32, r: f64| -> i64 {
            let slack = extent as i64 - window as i64;
            if slack >= 0 {
                ((slack + 1) as f64 * r).floor().min(slack as f64) as i64
            } else {
                slack / 2
            }
        };
        let crop = Crop {
            x: place(scaled.width, self.crop_size.width, d.next()),
            y: place(scaled.height, self.crop_size.height, d.next()),
            width: self.crop_size.width,
            height: self.crop_size.height,
        };
        View {
            index,
            scale,
            scaled,
            crop,
            attempt,
        }
    }

    /// Intrinsics and size of a view of a canvas with intrinsics `k`.
    pub fn view_camera(view: &View, k: Intrinsics, canvas: ImageSize) -> (Intrinsics, ImageSize) {
        crop_intrinsics(resize_intrinsics(k, canvas, view.scaled), &view.crop)
    }
}

/// The output id of view `index` of frame `id`: numeric, so KITTI loaders read it
/// (frame × count + index, six digits at least).
pub fn view_id(id: &str, count: u32, index: u32) -> Option<String> {
    let n: u64 = id.parse().ok()?;
    Some(format!(
        "{:06}",
        n.checked_mul(count as u64)?.checked_add(index as u64)?
    ))
}
