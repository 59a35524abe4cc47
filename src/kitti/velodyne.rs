//! KITTI velodyne scans (`velodyne/NNNNNN.bin`): little-endian float32 x, y, z, reflectance per
//! point, in the LiDAR frame (x forward, y left, z up), metres.

use crate::error::{Error, Result};
use nalgebra::Vector3;
use std::path::Path;

const POINT_BYTES: usize = 16;

/// A Velodyne scan (`velodyne/NNNNNN.bin`: float32 x, y, z, reflectance per point).
#[derive(Debug, Clone, Default)]
pub struct Scan {
    /// Points in the Velodyne frame (x forward, y left, z up), metres.
    pub points: Vec<Vector3<f64>>,
    /// Each point's reflectance, 0 to 1.
    pub reflectance: Vec<f32>,
    /// Points with a NaN or infinite coordinate, dropped and counted.
    pub dropped_non_finite: usize,
}

/// What is wrong with a scan of `len` bytes by its length alone (not a whole number of
/// points), or None: what [`parse`] refuses, and what `panoconv inspect` reports.
pub fn length_problem(len: u64) -> Option<String> {
    (!len.is_multiple_of(POINT_BYTES as u64)).then(|| {
        format!(
            "{len} bytes is not a whole number of 16-byte points (x, y, z, reflectance as float32): truncated or not a velodyne scan"
        )
    })
}

/// Parses a scan; a size that is not a whole number of points is a broken file.
pub fn parse(bytes: &[u8], path: &Path) -> Result<Scan> {
    if let Some(problem) = length_problem(bytes.len() as u64) {
        return Err(Error::file(path, problem));
    }
    let mut scan = Scan::default();
    scan.points.reserve(bytes.len() / POINT_BYTES);
    scan.dropped_non_finite = parse_points(bytes, &mut |p, r| {
        scan.points.push(p);
        scan.reflectance.push(r);
    });
    Ok(scan)
}

/// Gives `point` each point of `bytes` (whole points) with a finite position; returns how many
/// it skipped for a non-finite coordinate.
fn parse_points(bytes: &[u8], point: &mut impl FnMut(Vector3<f64>, f32)) -> usize {
    let mut dropped = 0;
    for chunk in bytes.chunks_exact(POINT_BYTES) {
        let f = |i: usize| f32::from_le_bytes([chunk[i], chunk[i + 1], chunk[i + 2], chunk[i + 3]]);
        let (x, y, z, r) = (f(0), f(4), f(8), f(12));
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            dropped += 1;
            continue;
        }
        point(Vector3::new(x as f64, y as f64, z as f64), r);
    }
    dropped
}

/// Bytes of a scan read at a time: whole points, few enough to stay in the cache from the
/// kernel's copy to the parse (a whole file is copied out to memory and read back).
const CHUNK_BYTES: usize = 4096 * POINT_BYTES;

/// Reads a scan file a chunk at a time, giving `point` each point with a finite position (LiDAR
/// frame) and its reflectance, in the file's order; returns how many points it skipped for a
/// non-finite coordinate. [`parse`]'s points and errors; on an error the points already given
/// are not a scan.
pub fn for_each_point(path: &Path, mut point: impl FnMut(Vector3<f64>, f32)) -> Result<usize> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf = vec![0u8; CHUNK_BYTES];
    let (mut filled, mut total, mut dropped) = (0, 0u64, 0);
    loop {
        let n = match file.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(Error::io(path, e)),
        };
        filled += n;
        total += n as u64;
        let whole = filled - filled % POINT_BYTES;
        dropped += parse_points(&buf[..whole], &mut point);
        buf.copy_within(whole..filled, 0);
        filled -= whole;
    }
    match length_problem(total) {
        Some(problem) => Err(Error::file(path, problem)),
        None => Ok(dropped),
    }
}

/// Reads and parses a scan file.
pub fn read(path: &Path) -> Result<Scan> {
    let mut scan = Scan::default();
    scan.dropped_non_finite = for_each_point(path, |p, r| {
        scan.points.push(p);
        scan.reflectance.push(r);
    })?;
    Ok(scan)
}

/// Encodes points (for synthetic scans and tests).
pub fn encode(points: &[(Vector3<f64>, f32)]) -> Vec<u8> {
    let mut out = Vec::with_capacity(points.len() * POINT_BYTES);
    for (p, r) in points {
        for v in [p.x as f32, p.y as f32, p.z as f32, *r] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// LiDAR points (LiDAR frame) to rect: X = R0_rect · Tr_velo_to_cam · p.
pub fn rect_from_velo(
    points: &[Vector3<f64>],
    r0_rect: &nalgebra::Matrix3<f64>,
    tr_velo_to_cam: &nalgebra::Matrix3x4<f64>,
) -> Vec<Vector3<f64>> {
    points
        .iter()
        .map(rect_from_velo_map(r0_rect, tr_velo_to_cam))
        .collect()
}

/// [`rect_from_velo`] of one point at a time.
pub fn rect_from_velo_map(
    r0_rect: &nalgebra::Matrix3<f64>,
    tr_velo_to_cam: &nalgebra::Matrix3x4<f64>,
) -> impl Fn(&Vector3<f64>) -> Vector3<f64> {
    let r0_rect = *r0_rect;
    let r = tr_velo_to_cam.fixed_view::<3, 3>(0, 0).into_owned();
    let t = tr_velo_to_cam.column(3).into_owned();
    move |p| r0_rect * (r * p + t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scan over three chunks with a non-finite point in each.
    fn scan_bytes() -> Vec<u8> {
        let points: Vec<(Vector3<f64>, f32)> = (0..2 * 4096 + 1000)
            .map(|i| {
                let x = if i % 4096 == 17 {
                    f64::NAN
                } else {
                    i as f64 * 0.25
                };
                (Vector3::new(x, -(i as f64), 0.5 * i as f64), (i % 7) as f32)
            })
            .collect();
        encode(&points)
    }

    #[test]
    fn a_scan_read_by_chunks_is_the_parse_of_the_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("000000.bin");
        let bytes = scan_bytes();
        std::fs::write(&path, &bytes).unwrap();
        let whole = parse(&bytes, &path).unwrap();
        let chunked = read(&path).unwrap();
        assert_eq!(chunked.points, whole.points);
        assert_eq!(chunked.reflectance, whole.reflectance);
        assert_eq!(chunked.dropped_non_finite, 3);
        assert_eq!(whole.dropped_non_finite, 3);
        assert_eq!(chunked.points.len(), 2 * 4096 + 1000 - 3);

        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let (a, b) = (
            read(&path).unwrap_err().to_string(),
            parse(&bytes[..bytes.len() - 5], &path)
                .unwrap_err()
                .to_string(),
        );
        assert_eq!(a, b);
        assert!(
            a.contains("000000.bin") && a.contains("not a whole number"),
            "{a}"
        );
    }
}
