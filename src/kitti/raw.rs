//! KITTI raw recordings: a date folder with `calib_cam_to_cam.txt`, `calib_velo_to_cam.txt`
//! and drives `*_drive_*_sync/{image_02,image_03,velodyne_points}/data/`. Each drive becomes a
//! split whose single calibration is written in KITTI object form (P0..P3 = P_rect_0x,
//! R0_rect = R_rect_00, Tr_velo_to_cam = [R | T]), so object-format readers take it.

use crate::error::{Error, Result};
use crate::fs::read_lines;
use crate::kitti::dataset::{Dataset, Layout, Split};
use crate::kitti::Calib;
use std::collections::HashMap;
use std::path::Path;

/// `key: numbers` lines of a raw calibration file (other lines, e.g. calib_time, are skipped).
fn numeric_lines(path: &Path) -> Result<HashMap<String, (usize, String)>> {
    let mut out = HashMap::new();
    for (i, line) in read_lines(path)?.iter().enumerate() {
        if let Some((k, v)) = line.split_once(':') {
            out.insert(k.trim().to_owned(), (i + 1, v.trim().to_owned()));
        }
    }
    Ok(out)
}

/// The drive calibration in KITTI object form.
pub fn compose_calib(date_dir: &Path) -> Result<Calib> {
    let c2c = date_dir.join("calib_cam_to_cam.txt");
    let v2c = date_dir.join("calib_velo_to_cam.txt");
    let cam = numeric_lines(&c2c)?;
    let velo = numeric_lines(&v2c)?;
    let get = |map: &HashMap<String, (usize, String)>, path: &Path, key: &str| -> Result<String> {
        map.get(key)
            .map(|(_, v)| v.clone())
            .ok_or_else(|| Error::file(path, format!("no {key} line")))
    };
    let mut lines = Vec::new();
    for n in 0..4 {
        if let Some((_, v)) = cam.get(&format!("P_rect_0{n}")) {
            lines.push(format!("P{n}: {v}"));
        }
    }
    lines.push(format!("R0_rect: {}", get(&cam, &c2c, "R_rect_00")?));
    let r: Vec<String> = get(&velo, &v2c, "R")?
        .split_whitespace()
        .map(str::to_owned)
        .collect();
    let t: Vec<String> = get(&velo, &v2c, "T")?
        .split_whitespace()
        .map(str::to_owned)
        .collect();
    if r.len() != 9 || t.len() != 3 {
        let line = velo.get("R").map_or(0, |(l, _)| *l);
        return Err(Error::parse(
            &v2c,
            line,
            "R/T",
            format!(
                "expected 9 and 3 numbers, found {} and {}",
                r.len(),
                t.len()
            ),
        ));
    }
    lines.push(format!(
        "Tr_velo_to_cam: {} {} {} {} {} {} {} {} {} {} {} {}",
        r[0], r[1], r[2], t[0], r[3], r[4], r[5], t[1], r[6], r[7], r[8], t[2]
    ));
    // errors in the composed numbers point at the cam-to-cam file, where most of them live
    Calib::parse(&c2c, lines)
}

/// Every drive of a date folder (or only `drive`).
pub fn open(date_dir: &Path, drive: Option<&str>) -> Result<Dataset> {
    if !date_dir.is_dir() {
        return Err(Error::Setup(format!(
            "input {} is not a directory",
            date_dir.display()
        )));
    }
    let calib = compose_calib(date_dir).map_err(|e| {
        Error::Setup(format!(
            "{e} (a KITTI raw date folder needs calib_cam_to_cam.txt and calib_velo_to_cam.txt)"
        ))
    })?;
    let mut names: Vec<String> = std::fs::read_dir(date_dir)
        .map_err(|e| Error::io(date_dir, e))?
        .flatten()
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str().map(str::to_owned))
        .filter(|n| n.contains("_drive_"))
        .collect();
    names.sort();
    if let Some(d) = drive {
        if !names.iter().any(|n| n == d) {
            return Err(Error::Setup(format!(
                "drive {d:?} not found in {} (drives: {})",
                date_dir.display(),
                names.join(", ")
            )));
        }
        names.retain(|n| n == d);
    }
    if names.is_empty() {
        return Err(Error::Setup(format!(
            "{} holds no *_drive_* folder",
            date_dir.display()
        )));
    }
    let mut splits = Vec::new();
    for name in names {
        let dir = date_dir.join(&name);
        let images = dir.join("image_02/data");
        let entries = std::fs::read_dir(&images)
            .map_err(|e| Error::Setup(format!("{}: {e}", images.display())))?;
        let (frames, unusable) = crate::kitti::dataset::list_frames(entries, &images)?;
        splits.push(Split {
            name,
            dir,
            has_labels: false,
            frames,
            unusable,
            layout: Layout::Raw {
                calib: Box::new(calib.clone()),
            },
        });
    }
    Ok(Dataset {
        root: date_dir.to_path_buf(),
        splits,
    })
}
