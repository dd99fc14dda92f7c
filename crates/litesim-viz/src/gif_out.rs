//! GIF output with a fixed palette.
//!
//! plotters' GIF backend quantises every frame with NeuQuant, which costs
//! more than drawing the frame. Our pictures use a handful of style colours
//! plus anti-aliased text, so a fixed palette does as well: the style's
//! colours exactly (obstacles, trajectories keep their true colour), then a
//! 6×6×6 colour cube and a grey ramp. Pixels map through a 15-bit lookup
//! table built once per file.

use crate::style::Style;
use crate::{VizError, draw_err};
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

/// Writes frames (RGB buffers) into a GIF, put in place atomically by
/// [`GifOut::finish`].
pub struct GifOut {
    enc: gif::Encoder<BufWriter<File>>,
    out: litesim_log::AtomicFile,
    width: u16,
    height: u16,
    delay_cs: u16,
    exact: Vec<([u8; 3], u8)>,
    lut: Vec<u8>,
    flagged: Vec<bool>,
    indices: Vec<u8>,
}

fn bucket(r: u8, g: u8, b: u8) -> usize {
    ((r as usize >> 3) << 10) | ((g as usize >> 3) << 5) | (b as usize >> 3)
}

impl GifOut {
    /// Starts `path` (atomically: [`litesim_log::AtomicFile`]) for a GIF of
    /// `w × h` frames shown `delay_ms` each.
    pub fn create(
        path: &Path,
        w: u32,
        h: u32,
        delay_ms: u32,
        style: &Style,
    ) -> Result<Self, VizError> {
        let mut palette: Vec<[u8; 3]> = Vec::with_capacity(256);
        let mut style_colours: Vec<String> = vec![
            style.background.clone(),
            style.free.clone(),
            style.inflated.clone(),
            style.obstacle.clone(),
            style.trajectory.clone(),
            style.corridor.clone(),
            style.raw_path.clone(),
            style.horizon.clone(),
            style.vehicle.clone(),
            style.samples.clone(),
            style.edges.clone(),
            style.lanes.clone(),
            "#000000".into(),
            "#ffffff".into(),
        ];
        style_colours.extend(style.series.iter().cloned());
        for c in style_colours {
            let c = style.c(&c);
            let rgb = [c.0, c.1, c.2];
            if !palette.contains(&rgb) && palette.len() < 40 {
                palette.push(rgb);
            }
        }
        let n_exact = palette.len();
        for r in 0..6u8 {
            for g in 0..6u8 {
                for b in 0..6u8 {
                    palette.push([r * 51, g * 51, b * 51]);
                }
            }
        }
        let mut k = 0u16;
        while palette.len() < 256 {
            let v = (8 + k * 247 / 40).min(255) as u8;
            palette.push([v, v, v]);
            k += 1;
        }
        palette.truncate(256);
        let lut: Vec<u8> = (0..32768usize)
            .map(|i| {
                let (r, g, b) = (
                    ((i >> 10) & 31) * 8 + 4,
                    ((i >> 5) & 31) * 8 + 4,
                    (i & 31) * 8 + 4,
                );
                let mut best = (u32::MAX, 0u8);
                for (j, p) in palette.iter().enumerate() {
                    let d = (p[0] as i32 - r as i32).pow(2)
                        + (p[1] as i32 - g as i32).pow(2)
                        + (p[2] as i32 - b as i32).pow(2);
                    if (d as u32) < best.0 {
                        best = (d as u32, j as u8);
                    }
                }
                best.1
            })
            .collect();
        let mut flagged = vec![false; 32768];
        let exact: Vec<([u8; 3], u8)> = palette[..n_exact]
            .iter()
            .enumerate()
            .map(|(i, p)| (*p, i as u8))
            .collect();
        for (p, _) in &exact {
            flagged[bucket(p[0], p[1], p[2])] = true;
        }
        let flat: Vec<u8> = palette.iter().flatten().copied().collect();
        let mut out = litesim_log::AtomicFile::create(path).map_err(crate::log_io)?;
        let file = out.file().try_clone().map_err(|e| VizError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        let (width, height) = (
            u16::try_from(w).map_err(draw_err)?,
            u16::try_from(h).map_err(draw_err)?,
        );
        let mut enc =
            gif::Encoder::new(BufWriter::new(file), width, height, &flat).map_err(draw_err)?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(draw_err)?;
        Ok(Self {
            enc,
            out,
            width,
            height,
            delay_cs: (delay_ms / 10).clamp(1, u16::MAX as u32) as u16,
            exact,
            lut,
            flagged,
            indices: vec![0; w as usize * h as usize],
        })
    }

    /// Appends one frame (RGB, row-major, `w × h`).
    pub fn push(&mut self, rgb: &[u8]) -> Result<(), VizError> {
        for (o, px) in self.indices.iter_mut().zip(rgb.chunks_exact(3)) {
            let bk = bucket(px[0], px[1], px[2]);
            *o = if self.flagged[bk] {
                self.exact
                    .iter()
                    .find(|(c, _)| c[0] == px[0] && c[1] == px[1] && c[2] == px[2])
                    .map_or(self.lut[bk], |e| e.1)
            } else {
                self.lut[bk]
            };
        }
        let mut frame =
            gif::Frame::from_indexed_pixels(self.width, self.height, &self.indices, None);
        frame.delay = self.delay_cs;
        self.enc.write_frame(&frame).map_err(draw_err)?;
        Ok(())
    }
}

impl GifOut {
    /// Ends the GIF (its trailer written, the buffer flushed, errors
    /// reported rather than dropped) and puts the file in place.
    pub fn finish(self) -> Result<(), VizError> {
        let path = self.out.path().display().to_string();
        let io = |e: std::io::Error| VizError::Io {
            path: path.clone(),
            message: e.to_string(),
        };
        let w = self.enc.into_inner().map_err(io)?;
        w.into_inner().map_err(|e| io(e.into_error()))?;
        self.out.commit().map_err(crate::log_io)
    }
}
