//! An augmented view's draw, whatever the dataset: the view drawn again (up to
//! `MAX_ATTEMPTS` times) until its camera holds `--min-objects` objects, else the draw that
//! holds most. `kitti/` (camera 2's views; camera 3 follows its draws) and `rig/` (the
//! stitched output's views) both draw through [`draw_view`].

use crate::camera::{ImageSize, OutputCamera};
use crate::error::Result;
use crate::geometry::augment::{Augment, View, MAX_ATTEMPTS};

/// How many objects an output camera holds.
pub(super) type CountObjects<'a> = dyn Fn(&dyn OutputCamera) -> Result<usize> + 'a;

/// A view's camera and how many objects it holds.
pub(super) struct Drawn {
    /// The view as drawn.
    pub(super) view: View,
    /// Its output camera.
    pub(super) camera: Box<dyn OutputCamera>,
    /// The objects it holds, if counted.
    pub(super) objects: Option<usize>,
}

/// Augmented view `index` of frame `frame` of `split`, on a canvas of `size`, its output
/// camera made by `camera`: with `count`, the first draw whose camera holds `aug.min_objects` objects, else the one holding most
/// (the first of those); without, the first draw.
pub(super) fn draw_view(
    aug: &Augment,
    (split, frame): (&str, &str),
    index: u32,
    size: ImageSize,
    camera: impl Fn(&View) -> Result<Box<dyn OutputCamera>>,
    count: Option<&CountObjects>,
) -> Result<Drawn> {
    let Some(count) = count else {
        let view = aug.view(split, frame, index, 0, size);
        return Ok(Drawn {
            camera: camera(&view)?,
            view,
            objects: None,
        });
    };
    let (drawn, _) = best_draw(
        aug.min_objects,
        |attempt| -> Result<Drawn> {
            let view = aug.view(split, frame, index, attempt, size);
            let drawn = camera(&view)?;
            let objects = Some(count(drawn.as_ref())?);
            Ok(Drawn {
                view,
                camera: drawn,
                objects,
            })
        },
        |drawn| Ok(drawn.objects.unwrap_or(0)),
    )?;
    Ok(drawn)
}

/// The first of up to `MAX_ATTEMPTS` draws (`draw(attempt)`, attempts 0, 1, ... in order)
/// whose `count` of objects reaches `min_objects`, else the draw holding most (the first of
/// those), with its count: the redraw rule of `--min-objects`, which the Python package's
/// `RandomCameraDataset` takes too.
pub fn best_draw<T, E>(
    min_objects: u32,
    mut draw: impl FnMut(u32) -> std::result::Result<T, E>,
    mut count: impl FnMut(&T) -> std::result::Result<usize, E>,
) -> std::result::Result<(T, usize), E> {
    let mut best: Option<(T, usize)> = None;
    for attempt in 0..MAX_ATTEMPTS.max(1) {
        let drawn = draw(attempt)?;
        let n = count(&drawn)?;
        if best.as_ref().is_none_or(|b| n > b.1) {
            best = Some((drawn, n));
        }
        if n >= min_objects as usize {
            break;
        }
    }
    Ok(best.expect("at least one draw"))
}
