//! Output callbacks of the driver: VTU frames at their interval and the PVD index.

use super::{RunError, RunOptions, output_error};
use crate::material::von_mises;
use crate::observe::Snapshot;
use crate::output::{Field, FieldData, PvdIndex, write_vtu};
use crate::scene::Case;
use crate::tensor::Dim;
use std::path::{Path, PathBuf};

/// VTU frames and their PVD index.
pub(super) struct Frames {
    index: Option<PvdIndex>,
    dir: PathBuf,
    name: String,
    interval: Option<f64>,
    next: f64,
    count: usize,
}

impl Frames {
    pub(super) fn new(case: &Case, opts: &RunOptions) -> Result<Self, RunError> {
        let index = if opts.frames {
            Some(
                PvdIndex::create(&opts.out_dir, &case.name).map_err(output_error(
                    &opts.out_dir.join(format!("{}.pvd", case.name)),
                ))?,
            )
        } else {
            None
        };
        Ok(Self {
            index,
            dir: opts.out_dir.clone(),
            name: case.name.clone(),
            interval: case.output.frame_interval,
            next: 0.0,
            count: 0,
        })
    }

    /// The time of the next frame and the times of those written (for a checkpoint).
    pub(super) fn progress(&self) -> (f64, Vec<f64>) {
        (
            self.next,
            self.index.as_ref().map_or_else(Vec::new, PvdIndex::times),
        )
    }

    /// Continues after the frames written before a checkpoint: lists them again (they
    /// must still be in the folder) and takes the next frame time.
    pub(super) fn resume(&mut self, next: f64, times: &[f64]) -> Result<(), RunError> {
        self.next = next;
        let Some(index) = &mut self.index else {
            return Ok(());
        };
        for &t in times {
            let file = frame_file(&self.name, self.count);
            index
                .push(t, &file)
                .map_err(output_error(&self.dir.join(&file)))?;
            self.count += 1;
        }
        Ok(())
    }

    /// Whether frames are written at all.
    pub(super) fn on(&self) -> bool {
        self.index.is_some()
    }

    /// Whether [`Self::write`] at time t writes a frame.
    pub(super) fn will_write(&self, t: f64, force: bool) -> bool {
        self.on() && (self.due(t) || force)
    }

    /// Time of the next frame (infinite when frames are off or have no interval).
    pub(super) fn next_time(&self) -> f64 {
        match (&self.index, self.interval) {
            (Some(_), Some(_)) => self.next,
            _ => f64::INFINITY,
        }
    }

    /// Whether a frame is due at time t.
    pub(super) fn due(&self, t: f64) -> bool {
        self.index.is_some() && self.interval.is_some() && t >= self.next * (1.0 - 1e-9)
    }

    /// Writes a frame when one is due (or `force`); `eta` is the hourglass indicator,
    /// given whenever [`Self::will_write`].
    pub(super) fn write<D: Dim>(
        &mut self,
        snap: &Snapshot<D>,
        t: f64,
        force: bool,
        eta: Option<&[f64]>,
    ) -> Result<(), RunError> {
        if !self.will_write(t, force) {
            return Ok(());
        }
        let (Some(index), Some(eta)) = (&mut self.index, eta) else {
            return Ok(());
        };
        let file = frame_file(&self.name, self.count);
        let path = self.dir.join(&file);
        write_frame::<D>(&path, snap, t, eta).map_err(output_error(&path))?;
        index
            .push(t, &file)
            .map_err(output_error(&self.dir.join(format!("{}.pvd", self.name))))?;
        self.count += 1;
        if let Some(interval) = self.interval {
            self.next = next_frame_time(self.next, interval, t);
        }
        Ok(())
    }
}

/// The file of frame k of a case.
fn frame_file(name: &str, k: usize) -> String {
    format!("{name}_{k:06}.vtu")
}

/// The time of the frame after one written at t: the next multiple of the interval past
/// t. One interval on from the previous frame time when that passes t (the common case);
/// else the multiple found directly, at least the next float after t, so that an
/// interval far below the resolution of t (or below the step) never loops.
pub(super) fn next_frame_time(previous: f64, interval: f64, t: f64) -> f64 {
    let past = t * (1.0 + 1e-9);
    let stepped = previous + interval;
    if stepped > past {
        return stepped;
    }
    let k = (past / interval).floor() + 1.0;
    (k * interval).max(past.next_up())
}

/// One VTU frame: current positions with u, v, F, σ, von Mises stress, J, the hourglass
/// indicator η, body, and the method's own fields (the plastic strain ε_p of a plastic
/// material).
pub fn write_frame<D: Dim>(
    path: &Path,
    snap: &Snapshot<D>,
    t: f64,
    eta: &[f64],
) -> std::io::Result<()> {
    let points: Vec<[f64; 3]> = snap
        .x0
        .iter()
        .zip(&snap.u)
        .map(|(&x, &u)| D::to3(x + u))
        .collect();
    let uu: Vec<[f64; 3]> = snap.u.iter().map(|&a| D::to3(a)).collect();
    let vv: Vec<[f64; 3]> = snap.v.iter().map(|&a| D::to3(a)).collect();
    let jac: Vec<f64> = snap.f.iter().map(|&f| D::det(f)).collect();
    let f9: Vec<[f64; 9]> = snap.f.iter().map(|&f| flatten(pad_f::<D>(f))).collect();
    let vm: Vec<f64> = snap.sigma.iter().map(von_mises).collect();
    let s9: Vec<[f64; 9]> = snap.sigma.iter().map(|s| flatten(*s)).collect();
    let body: Vec<i32> = snap.body.iter().map(|&b| b as i32).collect();
    let mut fields = vec![
        Field {
            name: "u",
            data: FieldData::Vector(&uu),
        },
        Field {
            name: "v",
            data: FieldData::Vector(&vv),
        },
        Field {
            name: "F",
            data: FieldData::Tensor(&f9),
        },
        Field {
            name: "sigma",
            data: FieldData::Tensor(&s9),
        },
        Field {
            name: "von_mises",
            data: FieldData::Scalar(&vm),
        },
        Field {
            name: "J",
            data: FieldData::Scalar(&jac),
        },
        Field {
            name: "hourglass",
            data: FieldData::Scalar(eta),
        },
        Field {
            name: "body",
            data: FieldData::Int(&body),
        },
    ];
    fields.extend(snap.extra.iter().map(|f| Field {
        name: f.name,
        data: FieldData::Scalar(&f.values),
    }));
    write_vtu(path, &points, &fields, t)
}

/// F as 3×3; in plane strain F_zz = 1.
fn pad_f<D: Dim>(f: D::T) -> [[f64; 3]; 3] {
    let mut m = D::to3x3(f);
    if D::N == 2 {
        m[2][2] = 1.0;
    }
    m
}

fn flatten(m: [[f64; 3]; 3]) -> [f64; 9] {
    let mut out = [0.0; 9];
    for k in 0..3 {
        out[3 * k..3 * k + 3].copy_from_slice(&m[k]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::next_frame_time;

    #[test]
    fn the_next_frame_time_passes_t_whatever_the_interval() {
        // One interval on from the last frame: exactly the sum, as frames are spaced.
        assert_eq!(next_frame_time(0.25, 0.25, 0.25), 0.5);
        // A step longer than the interval skips to the next multiple past t.
        let next = next_frame_time(0.25, 0.25, 1.1);
        assert!((next - 1.25).abs() < 1e-15, "{next}");
        // An interval below the resolution of t: just past t, without looping.
        let t = 1.0e-3;
        let next = next_frame_time(0.0, 1e-22, t);
        assert!(next > t * (1.0 + 1e-9) && next < t * (1.0 + 1e-8), "{next}");
    }
}
