//! Output callbacks of the driver: VTU frames at their interval and the PVD index. A
//! distributed run's engine writes each frame in pieces, one a rank, with a parallel
//! index (`.pvtu`) that the PVD index lists ([`FramePieces`]).

use super::batch::{Batch, Callback, IndicatorFits, Needs};
use super::budget::check_room;
use super::{Engine, RunError, RunOptions, checkpoint, output_error};
use crate::core::tensor::Dim;
use crate::diagnostics::observe::{Clock, IndicatorFields, Snapshot};
use crate::engine::BlowUp;
use crate::engine::ranks::FrameStore;
use crate::output::{
    Field, FieldData, Mesh, PieceArrays, PvdIndex, free_bytes, write_pvtu, write_vtu,
};
use crate::physics::material::von_mises;
use crate::physics::plasticity::symmetric_eigen;
use crate::physics::pressure::pressures;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// VTU frames and their PVD index.
pub(super) struct Frames {
    index: Option<PvdIndex>,
    dir: PathBuf,
    name: String,
    interval: Option<f64>,
    next: f64,
    count: usize,
    /// The size of the last frame written [bytes].
    last_bytes: Option<u64>,
    /// Whether the frames' room on the disk was checked (after the first one written).
    room_checked: bool,
    /// The engine writes each frame in pieces (a distributed run), which the index lists
    /// by their `.pvtu`.
    pieces: bool,
    /// The case file and end time, for the check that the frames fit on the disk.
    file: PathBuf,
    end_time: f64,
    constants: FrameConstants,
}

/// What a frame needs from the case besides the snapshot.
#[derive(Clone, Copy, Debug)]
pub struct FrameConstants {
    /// Reference density ρ0: V0 = m/ρ0, V = V0 J and ρ = ρ0/J.
    pub rho0: f64,
    /// The case's smoothing length, for the methods that give none per particle.
    pub h: f64,
}

impl FrameConstants {
    pub fn of(case: &Scene) -> Self {
        Self {
            rho0: case.material.density,
            h: case.smoothing_length(),
        }
    }
}

impl Frames {
    /// The frames of a run whose engine writes them in `pieces`, or not.
    pub(super) fn new(case: &Scene, opts: &RunOptions, pieces: bool) -> Result<Self, RunError> {
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
            last_bytes: None,
            room_checked: false,
            pieces,
            file: case.file.clone(),
            end_time: case.run.end_time,
            constants: FrameConstants::of(case),
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
    /// must still be in the folder, whole or in pieces, as the run that wrote them ran)
    /// and takes the next frame time.
    pub(super) fn resume(&mut self, next: f64, times: &[f64]) -> Result<(), RunError> {
        self.next = next;
        let Some(index) = &mut self.index else {
            return Ok(());
        };
        for &t in times {
            let (whole, pieces) = (
                frame_file(&self.name, self.count),
                index_file(&self.name, self.count),
            );
            let file = match self.dir.join(&whole).is_file() {
                true => whole,
                false => pieces,
            };
            index
                .push(t, &file)
                .map_err(output_error(&self.dir.join(&file)))?;
            self.count += 1;
        }
        Ok(())
    }

    /// Whether frames are written at all.
    fn on(&self) -> bool {
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

    /// Writes a frame of `snap` when one is due (or `force`); `fields` holds the hourglass
    /// indicator and the pressure deviation whenever [`Self::will_write`].
    pub(super) fn write<D: Dim>(
        &mut self,
        snap: &Snapshot<D>,
        clock: &Clock,
        force: bool,
        fields: &IndicatorFields,
    ) -> Result<(), RunError> {
        if !self.will_write(clock.t, force) {
            return Ok(());
        }
        let (Some(eta), Some(deviation)) = (&fields.eta, &fields.pressure_deviation) else {
            return Ok(());
        };
        let file = frame_file(&self.name, self.count);
        let path = self.dir.join(&file);
        let indicators = [eta.as_slice(), deviation];
        write_frame::<D>(&path, snap, clock.t, indicators, self.constants, None)
            .map_err(output_error(&path))?;
        let bytes = std::fs::metadata(&path).map_or(0, |m| m.len());
        self.listed(clock, &file, bytes)
    }

    /// Has the engine write a frame in pieces when one is due (or `force`).
    fn write_pieces<D: Dim>(
        &mut self,
        engine: &mut dyn Engine<D>,
        clock: &Clock,
        force: bool,
    ) -> Result<(), RunError> {
        if !self.will_write(clock.t, force) {
            return Ok(());
        }
        let file = index_file(&self.name, self.count);
        let bytes =
            (engine.write_frame_pieces(self.count, clock.t)).map_err(|e| RunError::Output {
                path: self.dir.join(&file),
                source: std::io::Error::other(e),
            })?;
        self.listed(clock, &file, bytes)
    }

    /// Lists the frame `file` of `bytes` written at the clock's time in the index and
    /// takes the next frame time; after the first, checks the room for those to come.
    fn listed(&mut self, clock: &Clock, file: &str, bytes: u64) -> Result<(), RunError> {
        self.remove_other_form()?;
        let index = self.index.as_mut().expect("frames are on");
        index
            .push(clock.t, file)
            .map_err(output_error(&self.dir.join(format!("{}.pvd", self.name))))?;
        self.last_bytes = Some(bytes);
        self.count += 1;
        if let Some(interval) = self.interval {
            self.next = next_frame_time(self.next, interval, clock.t);
        }
        if !std::mem::replace(&mut self.room_checked, true) {
            self.check_room(clock.dt)?;
        }
        Ok(())
    }
}

impl Frames {
    /// Removes the current frame in the form this run does not write (whole on one rank,
    /// in pieces on several), which an earlier run resumed here wrote past its
    /// checkpoint: a resumed run finds each frame it lists in one form only.
    fn remove_other_form(&self) -> Result<(), RunError> {
        let k = self.count;
        let stale = match self.pieces {
            true => vec![frame_file(&self.name, k)],
            false => vec![index_file(&self.name, k), folder(&self.name, k)],
        };
        for name in stale {
            let path = self.dir.join(name);
            let removed = match std::fs::symlink_metadata(&path) {
                Ok(m) if m.is_dir() => std::fs::remove_dir_all(&path),
                Ok(_) => std::fs::remove_file(&path),
                Err(_) => Ok(()),
            };
            removed.map_err(output_error(&path))?;
        }
        Ok(())
    }

    /// The bytes of the frames still to come up to the end time in steps of `dt`, by the
    /// size of the last one written (each holds the same fields): those at the
    /// interval's times, at most one a step, and the last one at the end. None before the
    /// first frame.
    fn bytes_to_come(&self, dt: f64) -> Option<u64> {
        let last = self.last_bytes?;
        let at_interval = match self.interval {
            Some(interval) if self.next <= self.end_time => {
                let per_interval = ((self.end_time - self.next) / interval).floor() + 1.0;
                per_interval.min((self.end_time / dt).ceil())
            }
            _ => 0.0,
        };
        // f64 to u64 saturates: a count past u64 is refused all the same.
        Some(last.saturating_mul((at_interval + 1.0) as u64))
    }

    /// Refuses frames that will not fit in the output folder's free space and warns when
    /// they take most of it (`budget::check_room`), once the first frame gives their size.
    fn check_room(&self, dt: f64) -> Result<(), RunError> {
        let (Some(bytes), Some(free)) = (self.bytes_to_come(dt), free_bytes(&self.dir)) else {
            return Ok(());
        };
        if let Some(warning) = check_room(&self.file, bytes, free, &self.dir)? {
            eprintln!("warning: {}: {warning}", self.file.display());
        }
        Ok(())
    }
}

impl<D: Dim> Callback<D> for Frames {
    fn next_time(&self) -> f64 {
        Frames::next_time(self)
    }

    fn needs(&self, clock: &Clock, last: bool) -> Needs {
        if self.pieces {
            return Needs::default();
        }
        Needs {
            state: self.due(clock.t) || last,
            frame: self.will_write(clock.t, last),
            ..Needs::default()
        }
    }

    fn after_batch(&mut self, batch: &mut Batch<D>) -> Result<Option<BlowUp>, RunError> {
        if self.pieces {
            return Ok(None);
        }
        if let (Some((snap, _)), Some(fields)) = (batch.state(), batch.fields()) {
            self.write(snap, &batch.clock, batch.last, fields)?;
        }
        Ok(None)
    }

    fn after_outputs(
        &mut self,
        engine: &mut dyn Engine<D>,
        clock: &Clock,
        last: bool,
    ) -> Result<(), RunError> {
        match self.pieces {
            true => self.write_pieces(engine, clock, last),
            false => Ok(()),
        }
    }

    fn save(&self, at: &mut checkpoint::Progress) {
        (at.next_frame, at.frames) = self.progress();
    }
}

/// The file of frame k of a case.
fn frame_file(name: &str, k: usize) -> String {
    format!("{name}_{k:06}.vtu")
}

/// The parallel index of frame k of a case written in pieces.
fn index_file(name: &str, k: usize) -> String {
    format!("{name}_{k:06}.pvtu")
}

/// The folder of the pieces of frame k of a case.
fn folder(name: &str, k: usize) -> String {
    format!("{name}_{k:06}")
}

/// The file of rank r's piece of a frame, in the frame's folder.
fn piece_name(r: usize) -> String {
    format!("rank-{r:05}.vtu")
}

/// Rank r's piece of frame k of a case.
fn piece_file(name: &str, k: usize, r: usize) -> String {
    format!("{}/{}", folder(name, k), piece_name(r))
}

/// A rank's pieces of the frames of a case ([`FrameStore`]): `<name>_<k>/rank-<r>.vtu`,
/// with the hourglass indicator and the pressure deviation of its own particles, and on
/// rank 0 the frame's index `<name>_<k>.pvtu`.
pub(super) struct FramePieces {
    dir: PathBuf,
    name: String,
    rank: usize,
    constants: FrameConstants,
    fits: IndicatorFits,
    /// The arrays of the rank's last piece, which the index declares (rank 0).
    arrays: Option<PieceArrays>,
}

impl FramePieces {
    /// Rank `rank`'s pieces of the frames of `case` in the run's folder.
    pub(super) fn new(case: &Scene, opts: &RunOptions, rank: usize, dim: usize) -> Self {
        Self {
            dir: opts.out_dir.clone(),
            name: case.name.clone(),
            rank,
            constants: FrameConstants::of(case),
            fits: IndicatorFits::new(case.kernel(dim)),
            arrays: None,
        }
    }
}

impl<D: Dim> FrameStore<D> for FramePieces {
    fn reach(&self) -> f64 {
        self.fits.reach()
    }

    fn derived(&mut self, all: &Snapshot<D>) -> [Vec<f64>; 2] {
        [self.fits.eta(all), self.fits.deviation(all)]
    }

    fn write(
        &mut self,
        frame: usize,
        t: f64,
        piece: &Snapshot<D>,
        ids: &[u32],
        ghosts: usize,
        derived: [&[f64]; 2],
    ) -> Result<u64, String> {
        let path = self.dir.join(piece_file(&self.name, frame, self.rank));
        let of = Piece { ids, ghosts };
        let written = (path.parent())
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| write_frame::<D>(&path, piece, t, derived, self.constants, Some(of)));
        self.arrays = written.map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(std::fs::metadata(&path).map_or(0, |m| m.len()))
    }

    fn index(&mut self, frame: usize, ranks: usize) -> Result<(), String> {
        // The pieces of ranks past this run's, left by an earlier run on more ranks.
        let dir = self.dir.join(folder(&self.name, frame));
        let ours: Vec<String> = (0..ranks).map(piece_name).collect();
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with("rank-") && name.ends_with(".vtu") && !ours.contains(&name) {
                let stale = entry.path();
                std::fs::remove_file(&stale).map_err(|e| format!("{}: {e}", stale.display()))?;
            }
        }
        let path = self.dir.join(index_file(&self.name, frame));
        let pieces: Vec<String> = (0..ranks)
            .map(|r| piece_file(&self.name, frame, r))
            .collect();
        let arrays = self.arrays.as_ref().ok_or("rank 0 wrote no piece")?;
        write_pvtu(&path, arrays, &pieces).map_err(|e| format!("{}: {e}", path.display()))
    }
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

/// One VTU frame: current positions with the particle id, reference position X, u, v, F,
/// the Green–Lagrange and logarithmic strains of F ([`strains`]), σ, pressure p = −tr σ/3, von Mises stress, J, mass, volume V = V0 J, density ρ0/J,
/// smoothing length, the hourglass indicator η and the pressure deviation δp
/// (`indicators`), body, and the method's own fields (the
/// plastic strain ε_p of a plastic material), which replace the derived field of the same
/// name (a UL method's own density, a per-particle smoothing length); the method's
/// elements, if it has them, as cells on the particles. A `piece` of a frame carries the
/// particles' global ids and flags its ghosts; for a piece, returns the arrays it holds.
pub fn write_frame<D: Dim>(
    path: &Path,
    snap: &Snapshot<D>,
    t: f64,
    indicators: [&[f64]; 2],
    constants: FrameConstants,
    piece: Option<Piece>,
) -> std::io::Result<Option<PieceArrays>> {
    let [eta, pressure_deviation] = indicators;
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
    let (green, hencky): (Vec<[f64; 9]>, Vec<[f64; 9]>) =
        snap.f.iter().map(|&f| strains(pad_f::<D>(f))).unzip();
    let body: Vec<i32> = snap.body.iter().map(|&b| b as i32).collect();
    let id: Vec<i32> = match &piece {
        Some(p) => p.ids.iter().map(|&g| g as i32).collect(),
        None => (0..snap.x0.len()).map(|i| i as i32).collect(),
    };
    let x0: Vec<[f64; 3]> = snap.x0.iter().map(|&a| D::to3(a)).collect();
    let pressure = pressures(&snap.sigma);
    let volume: Vec<f64> = snap
        .mass
        .iter()
        .zip(&jac)
        .map(|(m, j)| m / constants.rho0 * j)
        .collect();
    let density: Vec<f64> = jac.iter().map(|j| constants.rho0 / j).collect();
    let h = vec![constants.h; snap.x0.len()];
    let mut fields = vec![
        Field {
            name: "id",
            data: FieldData::Int(&id),
        },
        Field {
            name: "X",
            data: FieldData::Vector(&x0),
        },
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
            name: "green_lagrange_strain",
            data: FieldData::Tensor(&green),
        },
        Field {
            name: "log_strain",
            data: FieldData::Tensor(&hencky),
        },
        Field {
            name: "sigma",
            data: FieldData::Tensor(&s9),
        },
        Field {
            name: "pressure",
            data: FieldData::Scalar(&pressure),
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
            name: "mass",
            data: FieldData::Scalar(snap.mass),
        },
        Field {
            name: "volume",
            data: FieldData::Scalar(&volume),
        },
        Field {
            name: "density",
            data: FieldData::Scalar(&density),
        },
        Field {
            name: "smoothing_length",
            data: FieldData::Scalar(&h),
        },
        Field {
            name: "hourglass",
            data: FieldData::Scalar(eta),
        },
        Field {
            name: "pressure_deviation",
            data: FieldData::Scalar(pressure_deviation),
        },
        Field {
            name: "body",
            data: FieldData::Int(&body),
        },
    ];
    // A method's own field replaces the one of the same name derived above (a UL method's
    // density ρ, a per-particle smoothing length).
    for f in &snap.extra {
        let data = FieldData::Scalar(&f.values);
        match fields.iter_mut().find(|g| g.name == f.name) {
            Some(g) => g.data = data,
            None => fields.push(Field { name: f.name, data }),
        }
    }
    let mesh = Mesh {
        corners: snap.cells,
        dim: D::N,
        ghosts: piece.map(|p| p.ghosts),
    };
    write_vtu(path, &points, &fields, t, mesh)?;
    Ok(piece.map(|_| PieceArrays::of(&fields)))
}

/// A rank's piece of a frame: the global ids of its points, the last `ghosts` of which
/// are other ranks' (corners of its cells).
#[derive(Clone, Copy, Debug)]
pub struct Piece<'a> {
    pub ids: &'a [u32],
    pub ghosts: usize,
}

/// F as 3×3; in plane strain F_zz = 1.
fn pad_f<D: Dim>(f: D::T) -> [[f64; 3]; 3] {
    let mut m = D::to3x3(f);
    if D::N == 2 {
        m[2][2] = 1.0;
    }
    m
}

/// The Green–Lagrange strain E = ½(FᵀF − I) and the logarithmic (Hencky) strain
/// ε = ½ ln(F Fᵀ) = Σ_k ln λ_k n_k ⊗ n_k, with λ_k the principal stretches and n_k the
/// eigenvectors of F Fᵀ (the Eulerian one, coaxial with σ for an isotropic law), of F as
/// 3 × 3 (in 2D with the F_zz of [`pad_f`]). NaN where F Fᵀ is not positive definite (a
/// particle whose F has failed).
fn strains(f: [[f64; 3]; 3]) -> ([f64; 9], [f64; 9]) {
    let f = glam::DMat3::from_cols_array_2d(&f).transpose();
    let green = 0.5 * (f.transpose() * f - glam::DMat3::IDENTITY);
    let (lambda2, n) = symmetric_eigen(f * f.transpose());
    let mut hencky = glam::DMat3::ZERO;
    for k in 0..3 {
        let (l2, nk) = (lambda2[k], n.col(k));
        let half_ln = if l2 > 0.0 { 0.5 * l2.ln() } else { f64::NAN };
        hencky += glam::DMat3::from_cols(nk * nk.x, nk * nk.y, nk * nk.z) * half_ln;
    }
    // Both symmetric: the column arrays are the row-major ones.
    let flat = |m: glam::DMat3| flatten(m.to_cols_array_2d());
    (flat(green), flat(hencky))
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
    use super::{FrameConstants, next_frame_time, write_frame};
    use crate::core::tensor::{D2, Dim};
    use crate::diagnostics::observe::{ScalarField, Snapshot};
    use crate::output::scratch::scratch;
    use crate::output::vtu::tests::read_field;

    #[test]
    fn a_frame_carries_what_a_particle_code_user_expects() {
        // Two 2D particles of mass 2 and 3 at ρ0 = 4 (V0 = 0.5, 0.75), the first stretched
        // to J = 2, the second unstretched, with known stresses: V = V0 J, ρ = ρ0/J,
        // p = −tr σ/3, the ids, X, the case's h and the indicators given; a method's own
        // density replaces ρ0/J.
        let x0 = [[0.0, 0.0], [1.0, 0.5]].map(|p| D2::from_slice(&p));
        let mass = [2.0, 3.0];
        let body = [0, 0];
        let f = vec![
            glam::DMat2::from_diagonal(glam::DVec2::new(2.0, 1.0)),
            D2::identity(),
        ];
        let sigma = vec![
            [[3.0, 1.0, 0.0], [1.0, 6.0, 0.0], [0.0, 0.0, 9.0]],
            [[-3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]],
        ];
        let snapshot = |extra| Snapshot::<D2> {
            x0: &x0,
            mass: &mass,
            body: &body,
            u: vec![D2::zero(); 2],
            v: vec![D2::zero(); 2],
            f: f.clone(),
            sigma: sigma.clone(),
            strain_energy: crate::core::sum::Exact::default(),
            extra,
            cells: &[],
            quadrature: None,
        };
        let (_dir, path) = scratch("frame.vtu");
        let constants = FrameConstants { rho0: 4.0, h: 0.13 };
        let indicators = [&[0.5, 0.25][..], &[-1.5, 2.5][..]];
        write_frame(
            &path,
            &snapshot(Vec::new()),
            0.0,
            indicators,
            constants,
            None,
        )
        .unwrap();
        let field = |name| read_field(&path, name);
        assert_eq!(field("hourglass"), [0.5, 0.25]);
        assert_eq!(field("pressure_deviation"), [-1.5, 2.5]);
        assert_eq!(field("id"), [0.0, 1.0]);
        assert_eq!(field("X"), [0.0, 0.0, 0.0, 1.0, 0.5, 0.0]);
        assert_eq!(field("mass"), mass);
        assert_eq!(field("volume"), [1.0, 0.75]);
        assert_eq!(field("density"), [2.0, 4.0]);
        assert_eq!(field("pressure"), [-6.0, 1.0]);
        assert_eq!(field("smoothing_length"), [0.13; 2]);
        // F = diag(2, 1) (plane strain, F_zz = 1): E_xx = ½(4 − 1), ε_xx = ln 2.
        assert_eq!(read_field(&path, "green_lagrange_strain")[0], 1.5);
        assert!((read_field(&path, "log_strain")[0] - 2f64.ln()).abs() < 1e-15);
        let own = vec![ScalarField {
            name: "density",
            values: vec![5.0, 6.0],
        }];
        write_frame(
            &path,
            &snapshot(own),
            0.0,
            [&[0.0; 2], &[0.0; 2]],
            constants,
            None,
        )
        .unwrap();
        assert_eq!(read_field(&path, "density"), [5.0, 6.0]);
    }

    #[test]
    fn the_strains_of_a_rotated_stretch_are_the_closed_forms() {
        // F = R(θ) diag(λ1, λ2, 1) with θ = 0.7, λ1 = 2, λ2 = 0.5: E = ½(U² − I) with
        // U = diag(λ1, λ2, 1) (the rotation drops out of FᵀF), and ε = R diag(ln λ1, ln λ2,
        // 0) Rᵀ (the left stretch's principal directions are R's columns). Jacobi's
        // eigenvectors are exact to 1e-15 relative: bound 1e-13 on each component.
        let (c, s) = (0.7f64.cos(), 0.7f64.sin());
        let r = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let l = [2.0f64, 0.5, 1.0];
        let f: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| r[i][j] * l[j]));
        let (green, hencky) = super::strains(f);
        for i in 0..3 {
            for j in 0..3 {
                let e = if i == j {
                    0.5 * (l[i] * l[i] - 1.0)
                } else {
                    0.0
                };
                let eps: f64 = (0..3).map(|k| r[i][k] * l[k].ln() * r[j][k]).sum();
                assert!(
                    (green[3 * i + j] - e).abs() < 1e-13,
                    "E_{i}{j} = {}",
                    green[3 * i + j]
                );
                assert!(
                    (hencky[3 * i + j] - eps).abs() < 1e-13,
                    "ε_{i}{j} = {}",
                    hencky[3 * i + j]
                );
            }
        }
        // A failed particle's F (det F < 0 makes F Fᵀ still positive; a zero column does
        // not) gives NaN, not a panic.
        let (_, singular) = super::strains([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
        assert!(singular.iter().any(|x| x.is_nan()), "{singular:?}");
    }

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
