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

/// Reads a scan file a chunk at a time (the kernel's copy stays in the cache), giving `chunk`
/// each chunk's points with a finite position (LiDAR frame) as columns x, y, z (scratch
/// columns, cleared for each chunk), in the file's order, for work in lanes; returns how many
/// points it skipped for a non-finite coordinate. [`parse`]'s points and errors, reflectance
/// aside; on an error the points already given are not a scan.
pub fn for_each_chunk(
    path: &Path,
    columns: &mut [Vec<f64>; 3],
    mut chunk: impl FnMut(&mut [Vec<f64>; 3]),
) -> Result<usize> {
    let mut dropped = 0;
    read_chunks(path, |bytes| {
        columns.iter_mut().for_each(Vec::clear);
        dropped += parse_points(bytes, &mut |p, _| {
            columns[0].push(p.x);
            columns[1].push(p.y);
            columns[2].push(p.z);
        });
        chunk(columns);
    })?;
    Ok(dropped)
}

/// Gives `chunk` a scan file's bytes a whole number of points at a time, in order; the file's
/// length is checked at its end.
fn read_chunks(path: &Path, mut chunk: impl FnMut(&[u8])) -> Result<()> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut buf = vec![0u8; CHUNK_BYTES];
    let (mut filled, mut total) = (0, 0u64);
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
        chunk(&buf[..whole]);
        buf.copy_within(whole..filled, 0);
        filled -= whole;
    }
    match length_problem(total) {
        Some(problem) => Err(Error::file(path, problem)),
        None => Ok(()),
    }
}

/// Reads and parses a scan file.
pub fn read(path: &Path) -> Result<Scan> {
    parse(&crate::fs::read_file(path)?, path)
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

/// [`rect_from_velo_map`] of columns of points (x, y, z, in place), lane by lane: the very
/// products and sums of nalgebra's matrix-vector products (each row's terms left to right), the
/// same bits, compiled for AVX2 where the processor has it.
pub fn rect_from_velo_columns(
    r0_rect: &nalgebra::Matrix3<f64>,
    tr_velo_to_cam: &nalgebra::Matrix3x4<f64>,
    columns: &mut [Vec<f64>; 3],
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above).
        return unsafe { rect_columns_avx2(r0_rect, tr_velo_to_cam, columns) };
    }
    rect_columns_any(r0_rect, tr_velo_to_cam, columns)
}

/// [`rect_from_velo_columns`] for AVX2.
///
/// # Safety
///
/// The processor must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn rect_columns_avx2(
    r0: &nalgebra::Matrix3<f64>,
    tr: &nalgebra::Matrix3x4<f64>,
    columns: &mut [Vec<f64>; 3],
) {
    rect_columns_any(r0, tr, columns)
}

#[inline(always)]
fn rect_columns_any(
    r0: &nalgebra::Matrix3<f64>,
    tr: &nalgebra::Matrix3x4<f64>,
    [x, y, z]: &mut [Vec<f64>; 3],
) {
    let (r0, tr) = (*r0, *tr);
    let n = x.len().min(y.len()).min(z.len());
    for i in 0..n {
        let p = [x[i], y[i], z[i]];
        let row = |m: &[f64; 3], p: &[f64; 3]| m[0] * p[0] + m[1] * p[1] + m[2] * p[2];
        let cam: [f64; 3] =
            std::array::from_fn(|r| row(&[tr[(r, 0)], tr[(r, 1)], tr[(r, 2)]], &p) + tr[(r, 3)]);
        let rect: [f64; 3] =
            std::array::from_fn(|r| row(&[r0[(r, 0)], r0[(r, 1)], r0[(r, 2)]], &cam));
        (x[i], y[i], z[i]) = (rect[0], rect[1], rect[2]);
    }
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

    /// The points [`for_each_chunk`] gives, and its count of points skipped.
    fn by_chunks(path: &Path) -> Result<(Vec<Vector3<f64>>, usize)> {
        let mut points = Vec::new();
        let dropped = for_each_chunk(path, &mut Default::default(), |c| {
            points.extend((0..c[0].len()).map(|i| Vector3::new(c[0][i], c[1][i], c[2][i])));
        })?;
        Ok((points, dropped))
    }

    #[test]
    fn a_scan_read_by_chunks_is_the_parse_of_the_whole_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("000000.bin");
        let bytes = scan_bytes();
        std::fs::write(&path, &bytes).unwrap();
        let whole = parse(&bytes, &path).unwrap();
        let (points, dropped) = by_chunks(&path).unwrap();
        assert_eq!(points, whole.points);
        assert_eq!(dropped, 3);
        assert_eq!(whole.dropped_non_finite, 3);
        assert_eq!(points.len(), 2 * 4096 + 1000 - 3);

        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        let (a, b) = (
            by_chunks(&path).unwrap_err().to_string(),
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

    #[test]
    fn rect_columns_are_the_map_of_each_point_bit_for_bit() {
        let r0 = nalgebra::Matrix3::new(
            0.9999239,
            0.00983776,
            -0.007445048,
            -0.009869795,
            0.9999421,
            -0.004278459,
            0.007402527,
            0.004351614,
            0.9999631,
        );
        let tr = nalgebra::Matrix3x4::new(
            7.533745e-03,
            -0.9999714,
            -6.16602e-04,
            -4.069766e-03,
            1.480249e-02,
            7.280733e-04,
            -0.9998902,
            -7.631618e-02,
            0.9998621,
            7.523790e-03,
            1.480755e-02,
            -0.2717806,
        );
        let map = rect_from_velo_map(&r0, &tr);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("000000.bin");
        std::fs::write(&path, scan_bytes()).unwrap();
        let (mut columns, mut points) = (Default::default(), Vec::new());
        let dropped = for_each_chunk(&path, &mut columns, |c| {
            rect_from_velo_columns(&r0, &tr, c);
            points.extend((0..c[0].len()).map(|i| [c[0][i], c[1][i], c[2][i]]));
        })
        .unwrap();
        let scan = read(&path).unwrap();
        assert_eq!(dropped, scan.dropped_non_finite);
        let want: Vec<[f64; 3]> = scan.points.iter().map(|p| map(p).into()).collect();
        let bits =
            |v: &[[f64; 3]]| -> Vec<[u64; 3]> { v.iter().map(|p| p.map(f64::to_bits)).collect() };
        assert_eq!(bits(&points), bits(&want));
        assert_eq!(points.len(), 2 * 4096 + 1000 - 3);
    }
}
