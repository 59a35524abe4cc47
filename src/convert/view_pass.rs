//! One frame's output views written through one path, whatever the dataset: each view's image
//! (through its `ImageMapping`), mask and depth PNG encoded here, the dataset's own files
//! (labels, calib, extras) added by its `ViewFiles`, then every file written atomically and
//! hashed, with the frame record's views and LiDAR record. Nothing is written before every
//! view's files are encoded, so a view that fails leaves the frame's earlier views unwritten.

use crate::codec::png::{self as png, PngCompression};
use crate::error::Result;
use crate::fs;
use crate::geometry::augment::View;
use crate::image::RgbImage;
use crate::reproject::depth::DepthMap;
use crate::run::manifest::{FrameRecord, FrameStatus, LidarRecord, ViewRecord};
use crate::warp::{ImageMapping, PngSource, RemapTable};
use std::path::{Path, PathBuf};

/// Where a view's image comes from.
pub(super) enum ViewImage<'a> {
    /// Already in the output camera (stitched, or styled after the warp).
    Warped(&'a RgbImage),
    /// A single table's source PNG, warped row by row as the encoder takes the rows (a
    /// stitch takes its cameras' decoded images: `Mapped`).
    Streamed(&'a RemapTable, &'a mut PngSource),
    /// The mapping applied to its decoded sources.
    Mapped(ImageMapping<'a>, Vec<&'a RgbImage>),
}

/// A view's files as the dataset adds them, in its order (the manifest's).
pub(super) struct ViewSink {
    compression: PngCompression,
    files: Vec<(PathBuf, Vec<u8>)>,
    lidar: Option<LidarRecord>,
}

impl ViewSink {
    /// The view's image, encoded as PNG at `path`.
    pub(super) fn image(&mut self, path: PathBuf, image: ViewImage) -> Result<()> {
        let bytes = match image {
            ViewImage::Warped(image) => png::encode_rgb8(image, self.compression),
            ViewImage::Streamed(table, source) => source.warp_encode(table, self.compression)?,
            ViewImage::Mapped(mapping, images) => mapping.encode(&images, self.compression),
        };
        self.files.push((path, bytes));
        Ok(())
    }

    /// The view's mask (where the mapping has a source) at `path`.
    pub(super) fn mask(&mut self, path: PathBuf, mapping: ImageMapping) {
        self.files.push((path, mapping.encode_mask()));
    }

    /// The view's depth map (see `view_depth`) as a 16-bit PNG at `path`; its record becomes
    /// the frame's (with `--augment`, the last view's).
    pub(super) fn depth(&mut self, path: PathBuf, (map, record): (DepthMap, LidarRecord)) {
        self.files.push((
            path,
            png::encode_gray16(map.width, map.height, &map.to_u16(), self.compression),
        ));
        self.lidar = Some(record);
    }

    /// One of the dataset's own files (labels, calib, extras).
    pub(super) fn file(&mut self, path: PathBuf, bytes: Vec<u8>) {
        self.files.push((path, bytes));
    }
}

/// A dataset's files for each of a frame's views.
pub(super) trait ViewFiles {
    /// What the dataset needs to write one view.
    type View;

    /// Adds `view`'s files to `sink`, in the manifest's order.
    fn view_files(&mut self, view: Self::View, sink: &mut ViewSink) -> Result<()>;
}

/// An output view of a frame: its output frame id, its `--augment` draw, the dataset's view.
pub(super) struct PassView<V> {
    /// The view's output frame id.
    pub(super) id: String,
    /// How the view was drawn, with `--augment`.
    pub(super) view: Option<View>,
    /// What the dataset's `ViewFiles` takes.
    pub(super) files: V,
}

/// What a frame's views give its `FrameRecord`.
pub(super) struct WrittenViews {
    /// (path relative to the output, blake3) of every file written, in order.
    pub(super) outputs: Vec<(String, String)>,
    /// The drawn views (with `--augment`).
    pub(super) views: Vec<ViewRecord>,
    /// The LiDAR record of the last view with a depth map.
    pub(super) lidar: Option<LidarRecord>,
}

impl WrittenViews {
    /// The record of a frame converted: its split and id, its inputs with their hashes, and
    /// these outputs, views and LiDAR record.
    pub(super) fn record(
        self,
        split: String,
        id: String,
        inputs: Vec<(String, String)>,
    ) -> FrameRecord {
        FrameRecord {
            split,
            id,
            status: FrameStatus::Ok,
            error: None,
            inputs,
            outputs: self.outputs,
            views: self.views,
            lidar: self.lidar,
        }
    }
}

/// Encodes every view's files through `files`, then writes them atomically under `output`
/// and hashes them.
pub(super) fn write_views<F: ViewFiles>(
    output: &Path,
    compression: PngCompression,
    views: impl IntoIterator<Item = PassView<F::View>>,
    files: &mut F,
) -> Result<WrittenViews> {
    let mut sink = ViewSink {
        compression,
        files: Vec::new(),
        lidar: None,
    };
    let mut records = Vec::new();
    for view in views {
        files.view_files(view.files, &mut sink)?;
        if view.view.is_some() {
            records.push(ViewRecord {
                id: view.id,
                view: view.view,
            });
        }
    }
    let mut outputs = Vec::with_capacity(sink.files.len());
    for (path, bytes) in &sink.files {
        fs::write_atomic(path, bytes)?;
        outputs.push((relative(output, path), fs::hash_hex(bytes)));
    }
    Ok(WrittenViews {
        outputs,
        views: records,
        lidar: sink.lidar,
    })
}

/// `path` relative to `root`, with `/` separators (the manifest's form).
pub(super) fn relative(root: &Path, path: &Path) -> String {
    path.strip_prefix(root)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}
