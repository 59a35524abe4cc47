//! A KITTI frame's annotations in an output camera: each neutral object or region of the
//! [`Frame`] placed by `reproject` (the exact outline of a 3D box, or a 2D box through the
//! source camera's bearings), then each label line written back by `kitti/` with its new 2D
//! box and truncation.

use crate::camera::CameraModel;
use crate::kitti::rig_output::dont_care_line;
use crate::kitti::{FrameLabels, Label, LabelItem};
use crate::reproject::source_box::{region_in_image, source_box_in_image, BoxInImage};
use crate::reproject::visibility::Visibility;
use crate::source::Frame;
use nalgebra::Vector3;

/// Where the object or region `item` of `frame` lies in `output`, a camera about `centre`
/// with the reference frame's axes; None when it has no image there.
fn place(
    frame: &Frame,
    item: LabelItem,
    centre: &Vector3<f64>,
    output: &dyn CameraModel,
) -> Option<BoxInImage> {
    match item {
        LabelItem::Object(i) => source_box_in_image(&frame.objects[i], centre, output),
        LabelItem::Region(i) => {
            let region = &frame.regions[i];
            region_in_image(region, frame.rig[region.camera].model.as_ref(), output)
        }
    }
}

/// The label file of `output`: the line of each label that has an image there, in the
/// file's order; an object that fails `visibility` is written as a DontCare region.
pub(super) fn label_text(
    labels: &FrameLabels,
    frame: &Frame,
    centre: &Vector3<f64>,
    output: &dyn CameraModel,
    visibility: &Visibility,
) -> String {
    let mut text = String::new();
    for (label, &item) in labels.file.labels.iter().zip(&labels.items) {
        if let Some(placed) = place(frame, item, centre, output) {
            let object = matches!(item, LabelItem::Object(_));
            if object && !visibility.sees(&placed) {
                text.push_str(&dont_care_line(placed.bounds));
            } else {
                text.push_str(&label.moved_line(placed.bounds, placed.truncation));
            }
            text.push('\n');
        }
    }
    text
}

/// How many objects (ignore regions aside) have an image in `output` that `visibility`
/// accepts (a region counts wherever it has an image).
pub(super) fn objects_in(
    labels: &FrameLabels,
    frame: &Frame,
    centre: &Vector3<f64>,
    output: &dyn CameraModel,
    visibility: &Visibility,
) -> u32 {
    labels
        .items
        .iter()
        .filter(|item| match item {
            LabelItem::Object(_) => true,
            LabelItem::Region(i) => !frame.regions[*i].is_ignore(),
        })
        .filter(|&&item| match place(frame, item, centre, output) {
            Some(placed) => !matches!(item, LabelItem::Object(_)) || visibility.sees(&placed),
            None => false,
        })
        .count() as u32
}

/// One label moved into an output camera ([`move_label`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MovedLabel {
    /// Its line there.
    pub line: String,
    /// Whether it counts as an object (`--min-objects`): an object the visibility rule
    /// accepts, or an object without a 3D box; not a DontCare region.
    pub object: bool,
}

/// One label in the output camera `output` of the source camera `source` (both about
/// `centre`, rect axes): its new line, or None when it left the image.
pub fn transform_label(
    label: &Label,
    centre: &Vector3<f64>,
    source: &dyn CameraModel,
    output: &dyn CameraModel,
) -> Option<String> {
    move_label(label, centre, source, output, &Visibility::OFF).map(|m| m.line)
}

/// One label in the output camera `output` of the source camera `source` (both about
/// `centre`, rect axes), as a conversion's label file writes it (an object that fails
/// `visibility` as a DontCare region) and its `--min-objects` count counts it; None when it
/// left the image.
pub fn move_label(
    label: &Label,
    centre: &Vector3<f64>,
    source: &dyn CameraModel,
    output: &dyn CameraModel,
    visibility: &Visibility,
) -> Option<MovedLabel> {
    let moved = |placed: BoxInImage, object| MovedLabel {
        line: label.moved_line(placed.bounds, placed.truncation),
        object,
    };
    match label.to_source_box() {
        Some(b) => {
            let placed = source_box_in_image(&b, centre, output)?;
            Some(if visibility.sees(&placed) {
                moved(placed, true)
            } else {
                MovedLabel {
                    line: dont_care_line(placed.bounds),
                    object: false,
                }
            })
        }
        None => {
            let region = label.to_region(0);
            let placed = region_in_image(&region, source, output)?;
            Some(moved(placed, !region.is_ignore()))
        }
    }
}
