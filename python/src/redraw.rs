//! `panoconv.best_draw`: the redraw rule of `--min-objects` (`convert::best_draw`) over
//! draws made in Python, so that `RandomCameraDataset` redraws its cameras as `--augment`
//! redraws its views.

use pyo3::prelude::*;

/// Calls `draw(attempt)` for attempts 0, 1, ... (up to the command's 16) until `count(drawn)`
/// reaches `min_objects`; returns `(drawn, count)` of that draw, else of the draw that counted
/// most (the first of those). An exception of `draw` or `count` stops the draws and is raised.
#[pyfunction]
pub fn best_draw<'py>(
    min_objects: u32,
    draw: &Bound<'py, PyAny>,
    count: &Bound<'py, PyAny>,
) -> PyResult<(Bound<'py, PyAny>, usize)> {
    panoconv::convert::best_draw(
        min_objects,
        |attempt| draw.call1((attempt,)),
        |drawn| count.call1((drawn,))?.extract::<usize>(),
    )
}
