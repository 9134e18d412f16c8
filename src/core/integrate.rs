//! Explicit time integrators: classical RK4, TVD-RK2, SSP-RK3 (Shu–Osher forms) and a
//! kick–drift–kick leapfrog (velocity Verlet) with one rate evaluation per step.
//!
//! Each scheme is written once, as data: a [`program`] of operations on four state-sized
//! buffers (the state `Y`, a `Stage`, the `Rates` and an accumulator `Acc`). The CPU
//! [`Integrator`] interprets it; the GPU engines record it (`gpu::program::Stepper`).

use serde::{Deserialize, Serialize};

/// Time integrator, as named in case files.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    Rk4,
    TvdRk2,
    SspRk3,
    Leapfrog,
}

impl IntegratorKind {
    pub const ALL: [IntegratorKind; 4] = [Self::Rk4, Self::TvdRk2, Self::SspRk3, Self::Leapfrog];

    /// Rate evaluations per step.
    pub fn stages(self) -> usize {
        match self {
            Self::Rk4 => 4,
            Self::TvdRk2 => 2,
            Self::SspRk3 => 3,
            Self::Leapfrog => 1,
        }
    }
}

/// The integrated state of a method, and the same layout for its rates; the default is
/// an empty one (of no particles).
pub trait OdeState: Clone + Default + Send + Sync {
    /// self += a · rate.
    fn axpy(&mut self, a: f64, rate: &Self);
    /// self = a · self + b · other.
    fn blend(&mut self, a: f64, b: f64, other: &Self);
    /// self = a · from + b · other (self shaped like `from`).
    fn blend_from(&mut self, a: f64, from: &Self, b: f64, other: &Self);
    /// Leapfrog kick: velocity += h · acceleration.
    fn kick(&mut self, h: f64, rate: &Self);
    /// Leapfrog drift: position += h · (own) velocity, every other field += h · rate.
    fn drift(&mut self, h: f64, rate: &Self);
    /// Appends every field, exactly, for a checkpoint.
    fn save(&self, out: &mut Vec<f64>);
    /// Reads the fields [`Self::save`] wrote from the front of `words` (and moves past
    /// them); Err when they do not fit this state's layout.
    fn load(&mut self, words: &mut &[f64]) -> Result<(), String>;
}

/// A method's right-hand side dy/dt = f(t, y).
pub trait OdeSystem {
    type State: OdeState;
    type Error;
    /// Writes dy/dt at (t, y) into `dydt`.
    fn rates(&mut self, t: f64, y: &Self::State, dydt: &mut Self::State)
    -> Result<(), Self::Error>;
    /// Called once before each step with its start time, size and state.
    fn begin_step(&mut self, _t: f64, _dt: f64, _y: &Self::State) {}
    /// Called once after each step with its end time and the new state, which it may
    /// change (a method's post-step correction, such as a velocity smoothing).
    fn end_step(&mut self, _t: f64, _y: &mut Self::State) {}
}

/// Pseudo-time iterations of a run with artificial compressibility.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PseudoTime {
    /// Iterations of the last step, summed over its stages.
    pub step: u64,
    /// Iterations since the run started.
    pub total: u64,
    /// The largest final residual of the last step's stages, relative to the velocity
    /// scale.
    pub residual: f64,
}

/// One of the four state-sized buffers of a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Buf {
    Y,
    Stage,
    Rates,
    Acc,
}

/// A coefficient of Δt: num·Δt/den (so that Δt/6 is one correctly rounded division).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OfDt(pub f64, pub f64);

impl OfDt {
    pub fn times(self, dt: f64) -> f64 {
        dt * self.0 / self.1
    }
}

/// The scalar b of a blend: a multiple of Δt or a constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Weight {
    Dt(OfDt),
    Const(f64),
}

impl Weight {
    pub fn at(self, dt: f64) -> f64 {
        match self {
            Self::Dt(c) => c.times(dt),
            Self::Const(b) => b,
        }
    }
}

/// One operation of a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    /// The rates of the state in `src`, at t + c·Δt, into `Rates`.
    Rates { src: Buf, c: f64 },
    /// `to` = `from`.
    Copy { from: Buf, to: Buf },
    /// out = a·from + b·x: in place where `from` is `out`, else a copy fused into the
    /// blend.
    Blend {
        out: Buf,
        from: Buf,
        x: Buf,
        a: f64,
        b: Weight,
    },
    /// v(out) += h·(rate of v), h a multiple of Δt.
    Kick { out: Buf, h: OfDt },
    /// u(out) += h·v(out); every field after v += h·rates.
    Drift { out: Buf, h: OfDt },
}

impl Op {
    /// The buffers the operation reads or writes (`Rates` for a kick or a drift), the
    /// last repeated when it touches two.
    pub fn buffers(self) -> [Buf; 3] {
        match self {
            Self::Rates { src, .. } => [src, Buf::Rates, Buf::Rates],
            Self::Copy { from, to } => [from, to, to],
            Self::Blend { out, from, x, .. } => [out, from, x],
            Self::Kick { out, .. } | Self::Drift { out, .. } => [out, Buf::Rates, Buf::Rates],
        }
    }
}

/// One rate evaluation of a step: of the state in `src` into `Rates`, the `index`-th of
/// the step. The leapfrog's priming evaluation (rates of `Y` before its first step) has
/// index 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Evaluation {
    pub src: Buf,
    pub index: usize,
}

/// Whether any operation of `program` reads or writes buffer `b`.
pub fn uses(program: &[Op], b: Buf) -> bool {
    program.iter().any(|op| op.buffers().contains(&b))
}

/// The operations of one step of each integrator. The leapfrog starts from the rates of
/// the previous step (or of a priming evaluation of `Y` before its first step).
pub fn program(kind: IntegratorKind) -> Vec<Op> {
    use Buf::*;
    let rates = |src, c| Op::Rates { src, c };
    let copy = |from, to| Op::Copy { from, to };
    // out = from + num/den·Δt·x; in place where `from` is `out`.
    let axpy = |out, from, x, num, den| Op::Blend {
        out,
        from,
        x,
        a: 1.0,
        b: Weight::Dt(OfDt(num, den)),
    };
    let mix = |out, x, a, b| Op::Blend {
        out,
        from: out,
        x,
        a,
        b: Weight::Const(b),
    };
    // TVD-RK2 and SSP-RK3 in Shu–Osher form begin alike, with two forward Euler steps
    // (Stage = Y + Δt f(Y), then Stage += Δt f(Stage) at t + Δt), before their blends.
    let shu_osher = |blends: Vec<Op>| {
        let mut ops = vec![
            rates(Y, 0.0),
            axpy(Stage, Y, Rates, 1.0, 1.0),
            rates(Stage, 1.0),
            axpy(Stage, Stage, Rates, 1.0, 1.0),
        ];
        ops.extend(blends);
        ops
    };
    match kind {
        IntegratorKind::Rk4 => {
            // k1 at t, into Acc = Y + Δt k1/6; then each later stage's rates at Stage = Y
            // + Δt k_prev/a_den at t + cΔt, into Acc with weight 1/b_den (the classical
            // tableau), the last into Y = Acc + Δt k4/6.
            let mut ops = vec![rates(Y, 0.0), axpy(Acc, Y, Rates, 1.0, 6.0)];
            for (a_den, c) in [(2.0, 0.5), (2.0, 0.5), (1.0, 1.0)] {
                ops.extend([axpy(Stage, Y, Rates, 1.0, a_den), rates(Stage, c)]);
                ops.push(if c < 1.0 {
                    axpy(Acc, Acc, Rates, 1.0, 3.0)
                } else {
                    axpy(Y, Acc, Rates, 1.0, 6.0)
                });
            }
            ops
        }
        IntegratorKind::TvdRk2 => shu_osher(vec![mix(Y, Stage, 0.5, 0.5)]),
        IntegratorKind::SspRk3 => shu_osher(vec![
            mix(Stage, Y, 0.25, 0.75),
            rates(Stage, 0.5),
            axpy(Stage, Stage, Rates, 1.0, 1.0),
            mix(Y, Stage, 1.0 / 3.0, 2.0 / 3.0),
        ]),
        IntegratorKind::Leapfrog => vec![
            Op::Kick {
                out: Y,
                h: OfDt(1.0, 2.0),
            },
            Op::Drift {
                out: Y,
                h: OfDt(1.0, 1.0),
            },
            copy(Y, Stage),
            Op::Kick {
                out: Stage,
                h: OfDt(1.0, 2.0),
            },
            rates(Stage, 1.0),
            Op::Kick {
                out: Y,
                h: OfDt(1.0, 2.0),
            },
        ],
    }
}

/// Bytes per particle the stage operations of one step move (rate evaluations aside),
/// by the minimum-traffic model: a copy reads and writes the state, a blend reads two
/// states and writes one (from another buffer or in place), a kick reads v and a and
/// writes v, a drift reads and writes u and the fields after v and reads v and their
/// rates. `state` and `velocity` are the
/// bytes per particle of the state and of v; u has v's size.
pub fn traffic(kind: IntegratorKind, state: f64, velocity: f64) -> f64 {
    let fields = state - 2.0 * velocity;
    program(kind)
        .into_iter()
        .map(|op| match op {
            Op::Rates { .. } => 0.0,
            Op::Copy { .. } => 2.0 * state,
            Op::Blend { .. } => 3.0 * state,
            Op::Kick { .. } => 3.0 * velocity,
            Op::Drift { .. } => 3.0 * velocity + 3.0 * fields,
        })
        .sum()
}

/// The rate evaluations of one step, in order.
pub fn evaluations(kind: IntegratorKind) -> Vec<Evaluation> {
    program(kind)
        .into_iter()
        .filter_map(|op| match op {
            Op::Rates { src, .. } => Some(src),
            _ => None,
        })
        .enumerate()
        .map(|(index, src)| Evaluation { src, index })
        .collect()
}

/// The operations of one step, in order, as `meshless run --explain` prints them;
/// `rates` describes one rate evaluation of the method.
pub fn describe_step(kind: IntegratorKind, rates: &str) -> Vec<String> {
    let of_dt = |h: OfDt| format!("{:.4}·Δt", h.0 / h.1);
    program(kind)
        .into_iter()
        .map(|op| match op {
            Op::Rates { src, .. } => format!("rates of {src:?}: {rates}"),
            Op::Copy { from, to } => format!("copy {from:?} → {to:?}"),
            Op::Blend { out, from, x, a, b } => {
                let b = match b {
                    Weight::Dt(h) => of_dt(h),
                    Weight::Const(b) => format!("{b:.4}"),
                };
                format!("{out:?} = {a:.4}·{from:?} + {b}·{x:?}")
            }
            Op::Kick { out, h } => format!("kick: v({out:?}) += {}·a", of_dt(h)),
            Op::Drift { out, h } => {
                let h = of_dt(h);
                format!("drift: u({out:?}) += {h}·v, fields after v += {h}·rates")
            }
        })
        .collect()
}

/// The CPU interpreter of an integrator's [`program`], with its buffers allocated once.
pub struct Integrator<S: OdeState> {
    kind: IntegratorKind,
    program: Vec<Op>,
    /// Stage, Rates, Acc.
    buffers: [S; 3],
    /// Leapfrog: whether `Rates` holds the rates of the current state.
    primed: bool,
}

impl<S: OdeState> Integrator<S> {
    /// Stage buffers shaped like `template`, those the integrator's program uses (the
    /// others stay empty).
    pub fn new(kind: IntegratorKind, template: &S) -> Self {
        let program = program(kind);
        let buffer = |b: Buf| {
            if uses(&program, b) {
                template.clone()
            } else {
                S::default()
            }
        };
        Self {
            kind,
            buffers: [buffer(Buf::Stage), buffer(Buf::Rates), buffer(Buf::Acc)],
            program,
            primed: false,
        }
    }

    pub fn kind(&self) -> IntegratorKind {
        self.kind
    }

    /// Appends what a step carries to the next (the leapfrog's rates of the current
    /// state, when primed): a flag word, then the rates.
    pub fn save(&self, out: &mut Vec<f64>) {
        out.push(f64::from(u8::from(self.primed)));
        if self.primed {
            self.buffers[1].save(out);
        }
    }

    /// Reads what [`Self::save`] wrote.
    pub fn load(&mut self, words: &mut &[f64]) -> Result<(), String> {
        let (&flag, rest) = words.split_first().ok_or("no integrator flag")?;
        *words = rest;
        self.primed = flag == 1.0;
        if self.primed {
            self.buffers[1].load(words)?;
        }
        Ok(())
    }

    /// Advances y by one step of size dt from time t.
    pub fn step<Sys: OdeSystem<State = S>>(
        &mut self,
        sys: &mut Sys,
        t: f64,
        dt: f64,
        y: &mut S,
    ) -> Result<(), Sys::Error> {
        sys.begin_step(t, dt, y);
        if self.kind == IntegratorKind::Leapfrog && !self.primed {
            sys.rates(t, y, &mut self.buffers[1])?;
            self.primed = true;
        }
        for op in &self.program {
            match *op {
                Op::Rates { src, c } => {
                    let [stage, rates, _] = &mut self.buffers;
                    let state = match src {
                        Buf::Y => &*y,
                        Buf::Stage => &*stage,
                        Buf::Rates | Buf::Acc => unreachable!("rates are of Y or Stage"),
                    };
                    sys.rates(t + c * dt, state, rates)?;
                }
                Op::Copy { from, to } => {
                    let (out, x) = pair(y, &mut self.buffers, to, from);
                    out.clone_from(x);
                }
                Op::Blend { out, from, x, a, b } if from == out => {
                    let (out, x) = pair(y, &mut self.buffers, out, x);
                    if a == 1.0 {
                        out.axpy(b.at(dt), x);
                    } else {
                        out.blend(a, b.at(dt), x);
                    }
                }
                Op::Blend { out, from, x, a, b } => {
                    // Out of its place while the others are read (an empty state there).
                    let mut target = std::mem::take(buffer(y, &mut self.buffers, out));
                    {
                        let (y, buffers) = (&*y, &self.buffers);
                        let read = |b: Buf| match b {
                            Buf::Y => y,
                            b => &buffers[b as usize - 1],
                        };
                        target.blend_from(a, read(from), b.at(dt), read(x));
                    }
                    *buffer(y, &mut self.buffers, out) = target;
                }
                Op::Kick { out, h } => {
                    let (out, rates) = pair(y, &mut self.buffers, out, Buf::Rates);
                    out.kick(h.times(dt), rates);
                }
                Op::Drift { out, h } => {
                    let (out, rates) = pair(y, &mut self.buffers, out, Buf::Rates);
                    out.drift(h.times(dt), rates);
                }
            }
        }
        sys.end_step(t + dt, y);
        Ok(())
    }
}

/// Buffer `b` of y and [Stage, Rates, Acc].
fn buffer<'a, S>(y: &'a mut S, buffers: &'a mut [S; 3], b: Buf) -> &'a mut S {
    match b {
        Buf::Y => y,
        b => &mut buffers[b as usize - 1],
    }
}

/// The buffer `out` to write and the distinct buffer `x` to read, of y and
/// [Stage, Rates, Acc].
fn pair<'a, S>(y: &'a mut S, buffers: &'a mut [S; 3], out: Buf, x: Buf) -> (&'a mut S, &'a S) {
    let index = |b: Buf| b as usize - 1;
    match (out, x) {
        (Buf::Y, Buf::Y) => unreachable!("an operation reads another buffer than it writes"),
        (Buf::Y, x) => (y, &buffers[index(x)]),
        (out, Buf::Y) => (&mut buffers[index(out)], y),
        (out, x) => {
            let (o, x) = (index(out), index(x));
            assert_ne!(o, x, "an operation reads another buffer than it writes");
            if o < x {
                let (lo, hi) = buffers.split_at_mut(x);
                (&mut lo[o], &hi[0])
            } else {
                let (lo, hi) = buffers.split_at_mut(o);
                (&mut hi[0], &lo[x])
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Harmonic oscillator ẍ = −x as (x, v) with an extra first-order field z, ż = −z.
    #[derive(Clone, Default)]
    struct Osc {
        x: f64,
        v: f64,
        z: f64,
    }

    impl OdeState for Osc {
        fn axpy(&mut self, a: f64, r: &Self) {
            self.x += a * r.x;
            self.v += a * r.v;
            self.z += a * r.z;
        }
        fn blend(&mut self, a: f64, b: f64, o: &Self) {
            self.x = a * self.x + b * o.x;
            self.v = a * self.v + b * o.v;
            self.z = a * self.z + b * o.z;
        }
        fn blend_from(&mut self, a: f64, f: &Self, b: f64, o: &Self) {
            *self = f.clone();
            self.blend(a, b, o);
        }
        fn kick(&mut self, h: f64, r: &Self) {
            self.v += h * r.v;
        }
        fn drift(&mut self, h: f64, r: &Self) {
            self.x += h * self.v;
            self.z += h * r.z;
        }
        fn save(&self, out: &mut Vec<f64>) {
            out.extend([self.x, self.v, self.z]);
        }
        fn load(&mut self, words: &mut &[f64]) -> Result<(), String> {
            let (&[x, v, z], rest) = words.split_first_chunk().ok_or("short")?;
            (self.x, self.v, self.z, *words) = (x, v, z, rest);
            Ok(())
        }
    }

    struct Sho;
    impl OdeSystem for Sho {
        type State = Osc;
        type Error = ();
        fn rates(&mut self, _t: f64, y: &Osc, d: &mut Osc) -> Result<(), ()> {
            *d = Osc {
                x: y.v,
                v: -y.x,
                z: -y.z,
            };
            Ok(())
        }
    }

    fn error(kind: IntegratorKind, steps: usize) -> f64 {
        let t_end = 2.0;
        let dt = t_end / steps as f64;
        let mut y = Osc {
            x: 1.0,
            v: 0.0,
            z: 1.0,
        };
        let mut integ = Integrator::new(kind, &y);
        for n in 0..steps {
            integ.step(&mut Sho, n as f64 * dt, dt, &mut y).unwrap();
        }
        let ex = (y.x - t_end.cos()).abs() + (y.v + t_end.sin()).abs();
        // The leapfrog advances z with the first-order Euler drift by design; the RK
        // schemes integrate every field at their full order.
        if kind == IntegratorKind::Leapfrog {
            ex
        } else {
            ex + (y.z - (-t_end).exp()).abs()
        }
    }

    #[test]
    fn integrators_converge_at_their_order() {
        for (kind, order) in [
            (IntegratorKind::Rk4, 4.0),
            (IntegratorKind::TvdRk2, 2.0),
            (IntegratorKind::SspRk3, 3.0),
            (IntegratorKind::Leapfrog, 2.0),
        ] {
            let (e1, e2) = (error(kind, 100), error(kind, 200));
            let measured = (e1 / e2).log2();
            // Asymptotic regime at 100–200 steps: the observed order lies within 0.15 of theory.
            assert!(
                (measured - order).abs() < 0.15,
                "{kind:?}: order {measured:.3} (errors {e1:e}, {e2:e})"
            );
        }
    }

    /// The stage traffic of a step against a count by hand from the schemes' stages: a
    /// state of 40 bytes per particle whose v takes 8 (u 8, further fields 24).
    #[test]
    fn stage_traffic_counts_each_operation_of_a_step() {
        let (state, velocity, fields) = (40.0, 8.0, 24.0);
        // Three kicks (v, a read, v written), one drift (u, v, fields and their rates)
        // and the copy into the stage.
        let leapfrog = 3.0 * 3.0 * velocity + 3.0 * velocity + 3.0 * fields + 2.0 * state;
        assert_eq!(traffic(IntegratorKind::Leapfrog, state, velocity), leapfrog);
        // Seven blends: Y into the accumulator, three times Y into the stage, two in place
        // into the accumulator and the accumulator into Y.
        let rk4 = 7.0 * 3.0 * state;
        assert_eq!(traffic(IntegratorKind::Rk4, state, velocity), rk4);
    }
}
