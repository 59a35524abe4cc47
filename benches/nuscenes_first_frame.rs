//! Time to the first frame of a nuScenes-format version, and the peak memory: the tables
//! indexed for the selection (streamed, only what it needs kept), then its first sample read
//! with its LiDAR scan. On trainval-sized tables (benches/nuscenes_tables.py):
//!
//!     cargo run --release --example nuscenes_first_frame -- DATAROOT v1.0-trainval [SCENE]
//!
//! prints the seconds to the index and to the first frame, the frames selected and the peak
//! resident memory (VmHWM).

use panoconv::nuscenes::{NuScenes, Options, Selection};
use std::path::Path;
use std::time::Instant;

fn peak_rss_mb() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (root, version) = (Path::new(&args[0]), &args[1]);
    let selection = Selection {
        scenes: args.get(2).map(|s| vec![s.clone()]),
        cameras: None,
    };
    let start = Instant::now();
    let ds = NuScenes::open(root, version, &selection)?;
    let indexed = start.elapsed().as_secs_f64();
    let items = ds.items()?;
    let frame = ds.frame(&items[0], &Options::default())?;
    let first = start.elapsed().as_secs_f64();
    println!(
        "{} scenes, {} frames selected; index {indexed:.1} s, first frame {first:.1} s \
         ({} cameras, {} boxes, {} LiDAR points); peak RSS {:.0} MB",
        ds.scenes.len(),
        items.len(),
        frame.frame.rig.len(),
        frame.frame.objects.len(),
        frame.frame.lidar.len(),
        peak_rss_mb()
    );
    Ok(())
}
