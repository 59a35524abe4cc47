//! The rules of a KITTI conversion's options, as a library step between the options as given
//! ([`KittiOptions`], what the command line says, field for field) and the job that runs
//! ([`KittiJob`]): every rule that needs no file is checked here, before the output folder is
//! locked or a style model loaded, and each can be tested without the binary.

use super::{KittiJob, KittiSource};
use crate::camera::OutputProjection;
use crate::convert::canvas_flags::CanvasFlags;
use crate::convert::run_options::RunOptions;
use crate::error::{Error, Result};
use crate::geometry::{FisheyeTarget, Target};
use crate::kitti::Cam;
use crate::reproject::visibility::Visibility;
use std::path::PathBuf;

/// A KITTI conversion's options as given, before their rules are checked.
#[derive(Debug, Clone)]
pub struct KittiOptions {
    /// The dataset's root.
    pub input: PathBuf,
    /// The options every conversion shares (output, mode, shard, style, augment, depth, ...).
    pub run: RunOptions,
    /// Which layout `input` has and what part of it is converted.
    pub source: KittiSource,
    /// `--to`: a projection, or a fisheye camera (then `camera` is its file).
    pub to: OutputProjection,
    /// `--camera FILE`: the fisheye target's camera.
    pub camera: Option<PathBuf>,
    /// `--pano-width`, `--px-per-deg`, `--full-360`, `--size`, `--crop`, `--resize`.
    pub canvas: CanvasFlags,
    /// `--mask`.
    pub mask: bool,
    /// The frames asked for (`--frames`, `--frames-from`, `--image-set`); None: all.
    pub frames: Option<Vec<String>>,
    /// `--cameras`, in any order, repeats allowed.
    pub cameras: Vec<Cam>,
    /// `--min-visible`: which placed objects are written as objects.
    pub visibility: Visibility,
}

impl KittiOptions {
    /// Checks the options' rules and makes the job: `--export` needs a whole object dataset,
    /// `--to fisheye` its camera file and none of the scale and canvas options (a fisheye
    /// target has its camera's), `--camera` only with `--to fisheye`, `--cameras` camera 2,
    /// `--augment` an object dataset. Reads the fisheye camera file, nothing else.
    pub fn validate(self) -> Result<KittiJob> {
        let raw = matches!(self.source, KittiSource::Raw { .. });
        if (raw || self.run.shard.is_some()) && self.run.export {
            return Err(Error::Setup(
                "--export needs a whole KITTI object dataset: not with kitti-raw or --shard (run panoconv export after merge)".into(),
            ));
        }
        let target = self.target()?;
        let mut cameras = self.cameras.clone();
        cameras.sort_unstable();
        cameras.dedup();
        if !cameras.contains(&Cam::C2) {
            return Err(Error::Setup(
                "--cameras must include 2 (labels and depth belong to camera 2)".into(),
            ));
        }
        self.run.validate()?;
        if raw && self.run.augment.is_some() {
            return Err(Error::Setup(
                "--augment is not available for KITTI raw drives (one calib per drive)".into(),
            ));
        }
        let run = self.run;
        Ok(KittiJob {
            input: self.input,
            output: run.output,
            source: self.source,
            target,
            mask: self.mask,
            frames: self.frames,
            mode: run.mode,
            png_compression: run.png_compression,
            style: run.style,
            augment: run.augment,
            cameras,
            depth: run.depth,
            shard: run.shard,
            visibility: self.visibility,
        })
    }

    /// What the frames are rendered into.
    fn target(&self) -> Result<Target> {
        match (self.to, &self.camera) {
            (OutputProjection::Fisheye, Some(file)) => {
                if let Some(flag) = self.canvas.sized_flag() {
                    return Err(Error::Setup(format!(
                        "{flag}: a fisheye target has the size and scale of its camera file \
                         (--crop and --resize apply)"
                    )));
                }
                Ok(Target::Fisheye {
                    camera: Box::new(FisheyeTarget::read(file)?),
                    crop: self.canvas.crop,
                    resize: self.canvas.resize,
                })
            }
            (OutputProjection::Fisheye, None) => Err(Error::Setup(
                "--to fisheye needs --camera FILE: a camera description or a KITTI-360, WoodScape \
                 or OpenCV calibration file (docs/fisheye.md); to convert fisheye images instead, \
                 `panoconv fisheye --camera CAMERA.json --to cylindrical`"
                    .into(),
            )),
            (OutputProjection::Linear(_), Some(_)) => Err(Error::Setup(
                "--camera describes the camera of --to fisheye".into(),
            )),
            (OutputProjection::Linear(projection), None) => {
                Ok(Target::Linear(self.canvas.single_camera_spec(projection)?))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{ImageSize, Projection};
    use crate::codec::png::PngCompression;
    use crate::geometry::augment::Augment;
    use crate::geometry::{Canvas, Scale};
    use crate::run::{OutputMode, Shard};

    fn options() -> KittiOptions {
        KittiOptions {
            input: "in".into(),
            run: RunOptions {
                output: "out".into(),
                mode: OutputMode::New,
                png_compression: PngCompression::Fast,
                depth: None,
                augment: None,
                shard: None,
                style: None,
                export: false,
            },
            source: KittiSource::Object { split: None },
            to: Projection::Equirect.into(),
            camera: None,
            canvas: CanvasFlags::default(),
            mask: false,
            frames: None,
            cameras: vec![Cam::C3, Cam::C2, Cam::C3],
            visibility: Visibility::default(),
        }
    }

    fn refusal(o: KittiOptions) -> String {
        match o.validate() {
            Err(Error::Setup(m)) => m,
            other => panic!("expected a set-up error, got {other:?}"),
        }
    }

    #[test]
    fn valid_options_make_the_job() {
        let job = options().validate().unwrap();
        assert_eq!(job.cameras, [Cam::C2, Cam::C3]);
        assert_eq!(job.target.projection(), Projection::Equirect);
        assert_eq!(job.target.scale(), Scale::SourceFocal);
        let job = KittiOptions {
            canvas: CanvasFlags {
                pano_width: Some(2048),
                full_360: true,
                ..Default::default()
            },
            ..options()
        }
        .validate()
        .unwrap();
        match job.target {
            Target::Linear(spec) => {
                assert_eq!(spec.scale, Scale::PanoWidth(2048));
                assert_eq!(spec.canvas, Canvas::Full360);
            }
            Target::Fisheye { .. } => panic!("a linear target was asked for"),
        }
    }

    #[test]
    fn each_rule_refuses_before_anything_is_read() {
        let fisheye = || KittiOptions {
            to: OutputProjection::Fisheye,
            camera: Some("no/such/camera.json".into()),
            ..options()
        };
        let canvas = |flags: CanvasFlags| KittiOptions {
            canvas: flags,
            ..options()
        };
        let m = refusal(KittiOptions {
            canvas: CanvasFlags {
                pano_width: Some(2048),
                ..Default::default()
            },
            ..fisheye()
        });
        assert!(m.starts_with("--pano-width: a fisheye target"), "{m}");
        let m = refusal(KittiOptions {
            canvas: CanvasFlags {
                size: Some(ImageSize::new(10, 10)),
                ..Default::default()
            },
            ..fisheye()
        });
        assert!(m.starts_with("--size:"), "{m}");
        let m = refusal(KittiOptions {
            camera: None,
            ..fisheye()
        });
        assert!(m.starts_with("--to fisheye needs --camera FILE"), "{m}");
        let m = refusal(KittiOptions {
            camera: Some("front.json".into()),
            ..options()
        });
        assert!(m.contains("--camera describes"), "{m}");
        let mut o = options();
        o.run.shard = Some(Shard { index: 0, count: 2 });
        o.run.export = true;
        let m = refusal(o);
        assert!(
            m.starts_with("--export needs a whole KITTI object dataset"),
            "{m}"
        );
        let mut o = options();
        o.source = KittiSource::Raw { drive: None };
        o.run.export = true;
        let m = refusal(o);
        assert!(m.starts_with("--export needs"), "{m}");
        let m = refusal(KittiOptions {
            cameras: vec![Cam::C3],
            ..options()
        });
        assert!(m.starts_with("--cameras must include 2"), "{m}");
        let m = refusal(canvas(CanvasFlags {
            pano_width: Some(0),
            ..Default::default()
        }));
        assert_eq!(m, "--pano-width must be positive");
        let m = refusal(canvas(CanvasFlags {
            px_per_deg: Some(f64::NAN),
            ..Default::default()
        }));
        assert_eq!(m, "--px-per-deg must be positive");
        let augment = Augment {
            count: 2,
            seed: 0,
            scale_range: (1.0, 1.0),
            crop_size: ImageSize::new(100, 50),
            min_objects: 0,
        };
        let mut o = options();
        o.source = KittiSource::Raw { drive: None };
        o.run.augment = Some(augment);
        let m = refusal(o);
        assert!(
            m.starts_with("--augment is not available for KITTI raw"),
            "{m}"
        );
        // A fisheye camera file that does not exist is named (read only once the rules pass).
        let e = fisheye().validate().unwrap_err().to_string();
        assert!(e.contains("no/such/camera.json"), "{e}");
    }
}
