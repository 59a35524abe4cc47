//! One output view's LiDAR depth map and its manifest counters, whatever the dataset: the
//! points projected straight into the final output camera (crops and resizes never resample
//! it), kept where the view's sources see them.

use crate::camera::CameraModel;
use crate::reproject::depth::{depth_map, DepthMap, OcclusionFilter};
use crate::run::manifest::LidarRecord;
use crate::warp::NO_SOURCE;
use nalgebra::Vector3;

/// Where a view's depth map has values: what its sources see.
#[derive(Clone, Copy)]
pub(super) enum DepthDomain<'a> {
    /// One source camera (about the output's centre, with its axes): the points inside its
    /// image.
    Source(&'a dyn CameraModel),
    /// Several cameras: every point inside the output image, then none where the per-pixel
    /// source index (`ImageMapping::apply`) is `NO_SOURCE`.
    Coverage(&'a [u8]),
}

/// A frame's LiDAR points as a view's depth map takes them.
pub(super) struct ViewLidar<'a> {
    /// The finite points, in the frame's reference frame.
    pub(super) points: &'a [Vector3<f64>],
    /// How many points the reader dropped for a non-finite coordinate.
    pub(super) non_finite: usize,
    /// The occlusion filter, if on.
    pub(super) filter: Option<&'a OcclusionFilter>,
}

/// The depth map of the view `output` (about `centre`, the reference frame's axes) over
/// `domain`, and its manifest record.
pub(super) fn view_depth(
    lidar: &ViewLidar,
    centre: &Vector3<f64>,
    output: &dyn CameraModel,
    domain: DepthDomain,
) -> (DepthMap, LidarRecord) {
    let (map, occluded) = match domain {
        DepthDomain::Source(source) => depth_map(
            lidar.points.iter().copied(),
            centre,
            output,
            source,
            lidar.filter,
        ),
        DepthDomain::Coverage(sources) => {
            let (mut map, occluded) = depth_map(
                lidar.points.iter().copied(),
                centre,
                output,
                output,
                lidar.filter,
            );
            for (d, s) in map.values.iter_mut().zip(sources) {
                if *s == NO_SOURCE {
                    *d = 0.0;
                }
            }
            (map, occluded)
        }
    };
    let record = LidarRecord {
        points: lidar.points.len() + lidar.non_finite,
        dropped_non_finite: lidar.non_finite,
        dropped_occluded: occluded,
        depth_pixels: map.valid(),
    };
    (map, record)
}
