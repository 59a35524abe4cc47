//! KITTI object and KITTI raw frames through the source seam: a frame of either layout read
//! as a neutral [`Frame`] (its rig of colour cameras in the rect frame, its labels as
//! [`SourceBox`](crate::source::SourceBox)es and [`SourceRegion`](crate::source::SourceRegion)s,
//! its scan in rect), with what only KITTI files give beside it: the calibration (written
//! again for the output cameras), the label lines (written back with their new 2D boxes), the
//! hash of every file read.
//!
//! The two layouts differ in where a frame's files are ([`Split`]'s paths) and in its
//! calibration: a file per frame (object) or one per drive, composed from the date folder
//! (raw). That difference is in [`Split::read_calib`] and nowhere downstream. KITTI frames
//! have no world transform (the raw drives' OXTS poses are not read).

use super::dataset::{Layout, Split};
use super::{velodyne, Calib, Cam, LabelFile};
use crate::camera::{ImageSize, Intrinsics, Perspective};
use crate::error::{Error, Result};
use crate::fs::{self, read_file, split_lines};
use crate::source::{Frame, LidarPoint, Pose, RigCamera, SourceBox, SourceRegion};
use crate::warp::PngSource;
use nalgebra::Matrix3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What is read of a frame.
#[derive(Debug, Clone, Copy)]
pub struct Wants<'a> {
    /// The cameras asked for: the rig is camera 2 (always: the labels' 2D boxes are in its
    /// pixels), then camera 3 when it is listed.
    pub cameras: &'a [Cam],
    /// The Velodyne scan, in rect.
    pub lidar: bool,
}

/// Where a line of the label file went in the neutral frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LabelItem {
    /// An object with a 3D box: `Frame::objects[i]`.
    Object(usize),
    /// A DontCare region or an object without a 3D box: `Frame::regions[i]`.
    Region(usize),
}

/// A frame's label file and where each of its lines went in the neutral frame.
#[derive(Debug, Clone)]
pub struct FrameLabels {
    /// The file, its lines' tokens kept for writing them back.
    pub file: LabelFile,
    /// One per label, in line order.
    pub items: Vec<LabelItem>,
}

/// A KITTI frame: the neutral frame and the KITTI files' own parts.
pub struct KittiFrame {
    /// Id, provenance (calib, labels, images, scan: the files read, in that order), the rig
    /// (camera 2, then camera 3; each a pinhole camera about its own centre, rect axes),
    /// objects and regions, the scan in rect.
    pub frame: Frame,
    /// The KITTI camera of each rig camera.
    pub cams: Vec<Cam>,
    /// The intrinsics of each rig camera (the scale an output keeps by default).
    pub intrinsics: Vec<Intrinsics>,
    /// Each rig camera's PNG, decoded by its first warp.
    pub images: Vec<PngSource>,
    /// The blake3 of each file of the frame's provenance, in its order.
    pub hashes: Vec<String>,
    /// The frame's calibration (its own file, or the drive's).
    pub calib: Calib,
    /// The label file, for splits that have labels.
    pub labels: Option<FrameLabels>,
    /// Scan points dropped for a NaN or infinite coordinate.
    pub dropped_non_finite: usize,
}

/// The files read for a frame, with their hashes.
#[derive(Default)]
struct Files {
    paths: Vec<PathBuf>,
    hashes: Vec<String>,
}

impl Files {
    fn read(&mut self, path: &Path) -> Result<Vec<u8>> {
        let bytes = read_file(path)?;
        self.record(path, &bytes);
        Ok(bytes)
    }

    fn record(&mut self, path: &Path, bytes: &[u8]) {
        self.paths.push(path.to_owned());
        self.hashes.push(fs::hash_hex(bytes));
    }
}

impl Split {
    /// Frame `id`'s calibration and the bytes of its file where the layout has one per frame
    /// (object), or a copy of the drive's (raw: None).
    pub fn read_calib(&self, id: &str) -> Result<(Calib, Option<Vec<u8>>)> {
        match &self.layout {
            Layout::Object => {
                let path = self.calib_path(id);
                let bytes = read_file(&path)?;
                let calib = Calib::parse(&path, split_lines(&bytes, &path)?)?;
                Ok((calib, Some(bytes)))
            }
            Layout::Raw { calib } => Ok(((**calib).clone(), None)),
        }
    }

    /// The calibration of the whole split, where the layout has one (raw drives).
    pub fn drive_calib(&self) -> Option<&Calib> {
        match &self.layout {
            Layout::Object => None,
            Layout::Raw { calib } => Some(calib),
        }
    }

    /// Reads frame `id`: its calibration, labels, images and (when asked) scan, parsed, the
    /// images' headers read (their pixels are decoded by the warp).
    pub fn read_frame(&self, id: &str, wants: Wants) -> Result<KittiFrame> {
        let mut files = Files::default();
        let (calib, file) = self.read_calib(id)?;
        if let Some(bytes) = file {
            files.record(&calib.path, &bytes);
        }
        if calib.projection.is_some() {
            return Err(Error::file(
                &calib.path,
                "this calib was written by panoconv (it has a projection: line): convert the original dataset",
            ));
        }
        calib.camera(Cam::C2)?;

        let labels = if self.has_labels {
            let path = self.label_path(id);
            let bytes = files.read(&path)?;
            Some(LabelFile::parse(&path, split_lines(&bytes, &path)?)?)
        } else {
            None
        };

        let cams: Vec<Cam> = std::iter::once(Cam::C2)
            .chain(wants.cameras.contains(&Cam::C3).then_some(Cam::C3))
            .collect();
        let (mut rig, mut intrinsics, mut images) = (Vec::new(), Vec::new(), Vec::new());
        for &cam in &cams {
            let source = calib.camera(cam)?;
            let path = self.image_path(cam, id);
            let image = PngSource::new(files.read(&path)?, &path)?;
            let (w, h) = image.size();
            rig.push(RigCamera {
                name: format!("image_{cam}"),
                model: Arc::new(Perspective::new(source.k, ImageSize::new(w, h))),
                reference_from_camera: Pose::new(Matrix3::identity(), source.centre),
                image: path,
                time: None,
            });
            intrinsics.push(source.k);
            images.push(image);
        }

        let (lidar, dropped_non_finite) = if wants.lidar {
            self.read_scan(id, &calib, &mut files)?
        } else {
            (Vec::new(), 0)
        };
        let (mut objects, mut regions) = (Vec::new(), Vec::new());
        let labels = labels.map(|file| frame_labels(file, &mut objects, &mut regions));
        Ok(KittiFrame {
            frame: Frame {
                id: id.to_owned(),
                provenance: files.paths,
                rig,
                objects,
                regions,
                lidar,
                world_from_reference: None,
                reference_from_lidar: None,
                lidar_from_imu: None,
                input_hashes: Vec::new(),
            },
            cams,
            intrinsics,
            images,
            hashes: files.hashes,
            calib,
            labels,
            dropped_non_finite,
        })
    }

    /// Frame `id`'s scan in rect (the calib's R0_rect and Tr_velo_to_cam), and how many points
    /// were dropped for a non-finite coordinate.
    fn read_scan(
        &self,
        id: &str,
        calib: &Calib,
        files: &mut Files,
    ) -> Result<(Vec<LidarPoint>, usize)> {
        let path = self.velodyne_path(id);
        let bytes = files.read(&path)?;
        let scan = velodyne::parse(&bytes, &path)?;
        let r0 = calib
            .r0_rect
            .ok_or_else(|| Error::file(&calib.path, "no R0_rect line (needed for --depth)"))?;
        let tr = calib.tr_velo_to_cam.ok_or_else(|| {
            Error::file(&calib.path, "no Tr_velo_to_cam line (needed for --depth)")
        })?;
        let lidar = velodyne::rect_from_velo(&scan.points, &r0, &tr)
            .into_iter()
            .zip(scan.reflectance)
            .map(|(position, intensity)| LidarPoint {
                position,
                intensity,
            })
            .collect();
        Ok((lidar, scan.dropped_non_finite))
    }
}

/// A label file's lines as the frame's boxes (into `objects`) and DontCare regions (into
/// `regions`), each line pointing at its item.
fn frame_labels(
    file: LabelFile,
    objects: &mut Vec<SourceBox>,
    regions: &mut Vec<SourceRegion>,
) -> FrameLabels {
    let items = file
        .labels
        .iter()
        .map(|label| match label.to_source_box() {
            Some(b) => {
                objects.push(b);
                LabelItem::Object(objects.len() - 1)
            }
            None => {
                // (in camera 2's pixels: rig camera 0)
                regions.push(label.to_region(0));
                LabelItem::Region(regions.len() - 1)
            }
        })
        .collect();
    FrameLabels { file, items }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::Dataset;

    fn sample() -> Dataset {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/synthetic_kitti");
        Dataset::open(&root, Some("training")).unwrap()
    }

    #[test]
    fn an_object_frame_is_its_rig_objects_regions_and_scan_in_rect() {
        let dataset = sample();
        let split = &dataset.splits[0];
        let cameras = [Cam::C2, Cam::C3];
        let wants = Wants {
            cameras: &cameras,
            lidar: true,
        };
        let kitti = split.read_frame("000001", wants).unwrap();
        let frame = &kitti.frame;
        // calib, labels, both images, the scan: read once each, in that order, with hashes
        let names: Vec<String> = frame
            .provenance
            .iter()
            .map(|p| p.strip_prefix(&split.dir).unwrap().display().to_string())
            .collect();
        assert_eq!(
            names,
            [
                "calib/000001.txt",
                "label_2/000001.txt",
                "image_2/000001.png",
                "image_3/000001.png",
                "velodyne/000001.bin"
            ]
        );
        assert_eq!(kitti.hashes.len(), 5);
        assert_eq!(kitti.cams, [Cam::C2, Cam::C3]);
        // each rig camera is a pinhole about its own centre C = -K⁻¹ P[:, 3], rect axes
        for (j, &cam) in kitti.cams.iter().enumerate() {
            let source = kitti.calib.camera(cam).unwrap();
            let rig = &frame.rig[j];
            assert_eq!(rig.centre(), source.centre);
            assert_eq!(rig.reference_from_camera.rotation, Matrix3::identity());
            assert_eq!(kitti.intrinsics[j], source.k);
            let (w, h) = kitti.images[j].size();
            assert_eq!(rig.model.size(), ImageSize::new(w, h));
        }
        assert_ne!(frame.rig[0].centre(), frame.rig[1].centre());
        // every label line is one object or one region, in line order
        let labels = kitti.labels.as_ref().unwrap();
        assert_eq!(labels.items.len(), labels.file.labels.len());
        assert_eq!(
            frame.objects.len() + frame.regions.len(),
            labels.file.labels.len()
        );
        for (label, item) in labels.file.labels.iter().zip(&labels.items) {
            match *item {
                LabelItem::Object(i) => {
                    let b = &frame.objects[i];
                    assert_eq!(b.class, label.kind);
                    assert!((b.bottom_centre() - label.location).norm() < 1e-12);
                    assert!((b.yaw() - label.rotation_y).abs() < 1e-12);
                }
                LabelItem::Region(i) => {
                    let r = &frame.regions[i];
                    assert_eq!(r.bounds, label.bbox);
                    assert_eq!(r.is_ignore(), label.is_dont_care());
                }
            }
        }
        assert!(
            frame.regions.iter().any(|r| r.is_ignore()),
            "000001 has a DontCare"
        );
        // the scan in rect: R0_rect · Tr_velo_to_cam · p
        let scan = velodyne::read(&split.velodyne_path("000001")).unwrap();
        assert_eq!(frame.lidar.len(), scan.points.len());
        let want = velodyne::rect_from_velo(
            &scan.points[..1],
            &kitti.calib.r0_rect.unwrap(),
            &kitti.calib.tr_velo_to_cam.unwrap(),
        );
        assert_eq!(frame.lidar[0].position, want[0]);
        assert!(frame.world_from_reference.is_none());
    }

    #[test]
    fn a_frame_reads_only_what_is_wanted_and_a_converted_calib_is_refused() {
        let dataset = sample();
        let split = &dataset.splits[0];
        let wants = Wants {
            cameras: &[Cam::C2],
            lidar: false,
        };
        let kitti = split.read_frame("000000", wants).unwrap();
        assert_eq!(kitti.frame.rig.len(), 1);
        assert_eq!(kitti.frame.provenance.len(), 3);
        assert!(kitti.frame.lidar.is_empty());
        assert!(split.drive_calib().is_none());

        let dir = tempfile::tempdir().unwrap();
        let mut copy = split.clone();
        copy.dir = dir.path().to_path_buf();
        std::fs::create_dir_all(dir.path().join("calib")).unwrap();
        let mut text = std::fs::read_to_string(split.calib_path("000000")).unwrap();
        text.push_str("projection: equirect\n");
        std::fs::write(copy.calib_path("000000"), text).unwrap();
        let err = copy.read_frame("000000", wants).err().unwrap().to_string();
        assert!(err.contains("written by panoconv"), "{err}");
    }
}
