//! The value parsers the commands share: sizes, crops, shards, ranges.

use panoconv::camera::ImageSize;
use panoconv::geometry::Crop;
use panoconv::run::Shard;

/// `WxH`.
pub(crate) fn parse_size(s: &str) -> std::result::Result<ImageSize, String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 2048x512")?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width {w:?}"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height {h:?}"))?;
    if w == 0 || h == 0 {
        return Err("width and height must be positive".into());
    }
    Ok(ImageSize::new(w, h))
}

/// `K/N`.
pub(crate) fn parse_shard(s: &str) -> std::result::Result<Shard, String> {
    let (k, n) = s
        .split_once('/')
        .ok_or("expected K/N, e.g. 3/16 (K from 0)")?;
    let k: u32 = k
        .trim()
        .parse()
        .map_err(|_| format!("bad shard index {k:?}"))?;
    let n: u32 = n
        .trim()
        .parse()
        .map_err(|_| format!("bad shard count {n:?}"))?;
    if n == 0 || k >= n {
        return Err(format!("shard {k}/{n}: need 0 <= K < N"));
    }
    Ok(Shard { index: k, count: n })
}

/// `X,Y,W,H`.
pub(crate) fn parse_crop(s: &str) -> std::result::Result<Crop, String> {
    let v: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, w, h] = v[..] else {
        return Err("expected X,Y,WIDTH,HEIGHT, e.g. 0,20,469,128".into());
    };
    let int = |t: &str| {
        t.parse::<i64>()
            .map_err(|_| format!("{t:?} is not an integer"))
    };
    let (width, height) = (int(w)?, int(h)?);
    if width <= 0 || height <= 0 || width > 65535 || height > 65535 {
        return Err("crop width and height must be between 1 and 65535".into());
    }
    Ok(Crop {
        x: int(x)?,
        y: int(y)?,
        width: width as u32,
        height: height as u32,
    })
}

/// `MIN,MAX`.
pub(crate) fn parse_range(s: &str) -> std::result::Result<(f64, f64), String> {
    let (a, b) = s.split_once(',').ok_or("expected MIN,MAX, e.g. 0.8,1.25")?;
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|_| format!("{t:?} is not a number"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if !(a > 0.0 && b >= a && b.is_finite()) {
        return Err("expected 0 < MIN <= MAX".into());
    }
    Ok((a, b))
}
