//! `data_3d_bboxes/train/SEQ.xml`: KITTI-360's 3D boxes in world coordinates (an OpenCV
//! `FileStorage` XML file). Each element with a `<transform>` is one box: `vertices` (8x3, the
//! box's corners in its own axes: the unit cube for KITTI-360), `transform` (4x4, world from
//! box, the size folded into its 3x3 part), `semanticId` (KITTI-360's *kittiId*, see
//! `classes.rs`), `instanceId`, `timestamp` (−1 for a static object; the frame number for each
//! per-frame entry of a dynamic one), `start_frame`/`end_frame` (the frames a static object
//! belongs to). World vertices are `R · v + T`, as kitti360Scripts' `annotation.py` makes them.
//!
//! Elements without a `<transform>` (none in the published files) are skipped, as there.

use super::classes::{class_name, kitti_type, label_type};
use crate::error::{Error, Result};
use crate::source::{Pose, SourceBox};
use nalgebra::{Matrix3, Matrix4, Vector3};
use std::path::Path;

/// Largest |cos| between two axes of a box's transform: beyond it the 3x3 part is sheared, not
/// a rotation times a scale.
const MAX_AXIS_COSINE: f64 = 1e-3;

/// One box of the XML file, in world coordinates.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldBox {
    /// 1-based line of the box's element, for reports.
    pub line: usize,
    /// The element's `<index>`, when present.
    pub index: Option<i64>,
    /// KITTI-360's kittiId (the `<semanticId>` element).
    pub kitti_id: i64,
    /// The object's instance id (with the class, the same object across frames).
    pub instance_id: i64,
    /// −1 for a static object, else the frame this entry of a dynamic object belongs to.
    pub timestamp: i64,
    /// First frame of a static object.
    pub start_frame: i64,
    /// Last frame of a static object.
    pub end_frame: i64,
    /// world_from_box as published (scale folded in).
    pub transform: Matrix4<f64>,
    /// The vertices in the box's own axes, as published.
    pub vertices: Vec<Vector3<f64>>,
    /// Geometric centre in the world.
    pub centre: Vector3<f64>,
    /// The box's unit axes in the world (columns; a rotation).
    pub axes: Matrix3<f64>,
    /// Full extent along each of `axes`, metres.
    pub extent: Vector3<f64>,
}

impl WorldBox {
    /// Whether the box is a static object (`timestamp` −1).
    pub fn is_static(&self) -> bool {
        self.timestamp == -1
    }

    /// Whether the box belongs to `frame`: a static one whose frame range holds it, a dynamic
    /// entry whose timestamp is it.
    pub fn in_frame(&self, frame: u32) -> bool {
        let f = frame as i64;
        if self.is_static() {
            self.start_frame <= f && f <= self.end_frame
        } else {
            self.timestamp == f
        }
    }

    /// The vertices in world coordinates, `R · v + T` (kitti360Scripts' `parseVertices`).
    pub fn world_vertices(&self) -> Vec<Vector3<f64>> {
        let r = self.transform.fixed_view::<3, 3>(0, 0);
        let t = self.transform.fixed_view::<3, 1>(0, 3);
        self.vertices.iter().map(|v| r * v + t).collect()
    }

    /// The KITTI-360 name of the box's class.
    pub fn class_name(&self) -> &'static str {
        class_name(self.kitti_id).unwrap_or("unknown")
    }

    /// The box as a neutral [`SourceBox`] in a frame given by `reference_from_world` (a rigid
    /// map whose y axis is world −z, as the level frame's). The box's height axis is the one
    /// of its axes nearest the world's vertical, pointed down (local +y); its length axis is
    /// the first of the two others in the published order (x before y before z), its width
    /// axis completes a right-handed frame. The class is the KITTI type, or the KITTI-360 name
    /// for a class KITTI has no type for.
    pub fn to_source(&self, reference_from_world: &Pose) -> SourceBox {
        let vertical = (0..3)
            .max_by(|&a, &b| self.axes[(2, a)].abs().total_cmp(&self.axes[(2, b)].abs()))
            .unwrap_or(2);
        let up = self.axes.column(vertical).into_owned();
        let down = if up.z > 0.0 { -up } else { up };
        let others: Vec<usize> = (0..3).filter(|&k| k != vertical).collect();
        let length = self.axes.column(others[0]).into_owned();
        let width = length.cross(&down);
        let world_from_box = Matrix3::from_columns(&[length, down, width]);
        SourceBox {
            centre: reference_from_world.apply(&self.centre),
            size: Vector3::new(
                self.extent[others[0]],
                self.extent[vertical],
                self.extent[others[1]],
            ),
            rotation: reference_from_world.rotation * world_from_box,
            class: kitti_type(self.kitti_id)
                .map_or_else(|| label_type(self.class_name()), str::to_owned),
            dataset_class: self.class_name().to_owned(),
            instance: u64::try_from(self.instance_id).ok(),
            truncation: None,
            occlusion: None,
            sensor_points: None,
            velocity: None,
            time: None,
        }
    }
}

/// The 1-based line of a node.
fn line_of(doc: &roxmltree::Document, node: roxmltree::Node) -> usize {
    doc.text_pos_at(node.range().start).row as usize
}

struct Reader<'a, 'input> {
    doc: &'a roxmltree::Document<'input>,
    path: &'a Path,
}

impl<'a, 'input> Reader<'a, 'input> {
    fn child(
        &self,
        node: roxmltree::Node<'a, 'input>,
        name: &str,
    ) -> Result<roxmltree::Node<'a, 'input>> {
        node.children()
            .find(|c| c.has_tag_name(name))
            .ok_or_else(|| {
                Error::parse(
                    self.path,
                    line_of(self.doc, node),
                    name,
                    format!("missing <{name}> in <{}>", node.tag_name().name()),
                )
            })
    }

    fn integer(&self, node: roxmltree::Node<'a, 'input>, name: &str) -> Result<i64> {
        let c = self.child(node, name)?;
        let text = c.text().unwrap_or("").trim();
        text.parse::<i64>().map_err(|_| {
            Error::parse(
                self.path,
                line_of(self.doc, c),
                name,
                format!("not an integer: {text:?}"),
            )
        })
    }

    /// An OpenCV matrix element: `<rows>`, `<cols>`, `<data>` (whitespace-separated numbers).
    fn matrix(
        &self,
        node: roxmltree::Node<'a, 'input>,
        name: &str,
        rows: usize,
        cols: usize,
    ) -> Result<Vec<f64>> {
        let m = self.child(node, name)?;
        let line = line_of(self.doc, m);
        let r = self.integer(m, "rows")?;
        let c = self.integer(m, "cols")?;
        if (r, c) != (rows as i64, cols as i64) {
            return Err(Error::parse(
                self.path,
                line,
                name,
                format!("expected a {rows}x{cols} matrix, found {r}x{c}"),
            ));
        }
        let data = self.child(m, "data")?;
        let data_line = line_of(self.doc, data);
        let field = format!("{name}.data");
        let values = data
            .text()
            .unwrap_or("")
            .split_whitespace()
            .enumerate()
            .map(|(i, v)| {
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| {
                        Error::parse(
                            self.path,
                            data_line,
                            format!("{field}[{i}]"),
                            format!("not a finite number: {v:?}"),
                        )
                    })
            })
            .collect::<Result<Vec<f64>>>()?;
        if values.len() != rows * cols {
            return Err(Error::parse(
                self.path,
                data_line,
                field,
                format!("{} values for a {rows}x{cols} matrix", values.len()),
            ));
        }
        Ok(values)
    }

    fn world_box(&self, node: roxmltree::Node<'a, 'input>) -> Result<WorldBox> {
        let line = line_of(self.doc, node);
        let kitti_id = self.integer(node, "semanticId")?;
        if class_name(kitti_id).is_none() {
            let c = self.child(node, "semanticId")?;
            return Err(Error::parse(
                self.path,
                line_of(self.doc, c),
                "semanticId",
                format!("{kitti_id} is not a KITTI-360 kittiId (1 to 37)"),
            ));
        }
        let index = match node.children().find(|c| c.has_tag_name("index")) {
            Some(_) => Some(self.integer(node, "index")?),
            None => None,
        };
        let t = self.matrix(node, "transform", 4, 4)?;
        let transform = Matrix4::from_row_slice(&t);
        let v = self.matrix(node, "vertices", 8, 3)?;
        let vertices: Vec<Vector3<f64>> = v
            .chunks_exact(3)
            .map(|c| Vector3::new(c[0], c[1], c[2]))
            .collect();
        let transform_line = line_of(self.doc, self.child(node, "transform")?);
        let bad = |message: String| Error::parse(self.path, transform_line, "transform", message);
        let bottom = transform.row(3);
        if bottom.iter().copied().ne([0.0, 0.0, 0.0, 1.0]) {
            return Err(bad("the last row must be 0 0 0 1".into()));
        }
        let (lo, hi) = vertices.iter().fold(
            (
                Vector3::repeat(f64::INFINITY),
                Vector3::repeat(f64::NEG_INFINITY),
            ),
            |(lo, hi), v| (lo.inf(v), hi.sup(v)),
        );
        let r = transform.fixed_view::<3, 3>(0, 0).into_owned();
        let (axes, extent) = rigid_axes(&r, &lo, &hi, bad)?;
        let centre_local = (lo + hi) / 2.0;
        Ok(WorldBox {
            line,
            index,
            kitti_id,
            instance_id: self.integer(node, "instanceId")?,
            timestamp: self.integer(node, "timestamp")?,
            start_frame: self.integer(node, "start_frame")?,
            end_frame: self.integer(node, "end_frame")?,
            centre: r * centre_local + transform.fixed_view::<3, 1>(0, 3),
            transform,
            vertices,
            axes,
            extent,
        })
    }
}

/// A box's axes and extents from its transform's 3x3 part `r` over its local bounds `lo`..`hi`:
/// the columns must be a rotation times a scale (perpendicular, right-handed, none flat); the
/// nearest rotation is returned, so that the neutral box is rigid whatever the rounding.
fn rigid_axes(
    r: &Matrix3<f64>,
    lo: &Vector3<f64>,
    hi: &Vector3<f64>,
    bad: impl Fn(String) -> Error,
) -> Result<(Matrix3<f64>, Vector3<f64>)> {
    let scaled: Vec<Vector3<f64>> = (0..3).map(|k| r.column(k) * (hi[k] - lo[k])).collect();
    let extent = Vector3::from_iterator(scaled.iter().map(|a| a.norm()));
    if !extent.iter().all(|e| *e > 1e-9) {
        return Err(bad("the box is flat: an axis has no extent".into()));
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let cos = scaled[i].dot(&scaled[j]) / (extent[i] * extent[j]);
        if cos.abs() > MAX_AXIS_COSINE {
            return Err(bad(format!(
                "columns {i} and {j} are not perpendicular (cos {cos:.2e}): not a rotation \
                 times a scale"
            )));
        }
    }
    let axes = Matrix3::from_columns(&[
        scaled[0] / extent[0],
        scaled[1] / extent[1],
        scaled[2] / extent[2],
    ]);
    if !(axes.determinant() > 0.0) {
        return Err(bad(
            "the box's axes are mirrored (negative determinant)".into()
        ));
    }
    let svd = axes.svd(true, true);
    let axes = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => u * v_t,
        _ => axes,
    };
    Ok((axes, extent))
}

/// Parses the text of a box file; `path` names it in errors.
pub fn parse_boxes(text: &str, path: &Path) -> Result<Vec<WorldBox>> {
    let doc = roxmltree::Document::parse(text)
        .map_err(|e| Error::parse(path, e.pos().row as usize, "xml", e.to_string()))?;
    let reader = Reader { doc: &doc, path };
    doc.root_element()
        .children()
        .filter(|n| n.is_element() && n.children().any(|c| c.has_tag_name("transform")))
        .map(|n| reader.world_box(n))
        .collect()
}

/// Reads a box file.
pub fn read_boxes(path: &Path) -> Result<Vec<WorldBox>> {
    let bytes = crate::fs::read_file(path)?;
    let text = String::from_utf8(bytes).map_err(|_| Error::file(path, "not valid UTF-8"))?;
    parse_boxes(&text, path)
}
