//! Deterministic parallel loops over particles and the field-wise arithmetic of a
//! particle state: the ordered reduction of the sums over particles that are not exact
//! ([`crate::core::sum`]), y += a x and y = a y + b x on rayon, the [`particle_state!`] macro that declares
//! a state of per-particle fields (u, v and the method's own) and makes it an
//! [`crate::core::integrate::OdeState`], and the checkpoint words of a field.

use crate::core::tensor::Words;
use rayon::prelude::*;
use std::ops::{Add, Mul};

/// Smallest slice length rayon splits down to: below it the per-task overhead dominates.
pub(crate) const MIN_CHUNK: usize = 256;

/// Reduces map(0), …, map(n − 1) with `add` in parallel, deterministically: in fixed
/// chunks of [`MIN_CHUNK`] indices, each folded in order, and the chunks' results then
/// folded in order, so the sum has the same bits whatever the number of threads and
/// however rayon steals work (rayon's `reduce` and `sum` combine in an order that
/// depends on both). Every floating-point sum over particles that is not an exact sum
/// ([`crate::core::sum::Exact`]) goes through it.
pub(crate) fn ordered_reduce<T: Send>(
    n: usize,
    identity: impl Fn() -> T + Sync,
    map: impl Fn(usize) -> T + Sync,
    add: impl Fn(T, T) -> T + Sync,
) -> T {
    let chunks: Vec<T> = (0..n.div_ceil(MIN_CHUNK))
        .into_par_iter()
        .map(|c| {
            (c * MIN_CHUNK..n.min((c + 1) * MIN_CHUNK))
                .map(&map)
                .fold(identity(), &add)
        })
        .collect();
    chunks.into_iter().fold(identity(), add)
}

/// y += a x, field by field.
pub(crate) fn axpy<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y + x * a);
}

/// y = a y + b x, field by field.
pub(crate) fn blend<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut [T],
    a: f64,
    b: f64,
    x: &[T],
) {
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(x)
        .for_each(|(y, &x)| *y = *y * a + x * b);
}

/// y = a f + b x, field by field, y first shaped like f (the bits of y = f, then
/// y = a y + b x, or y += b x where a = 1).
pub(crate) fn blend_from<T: Copy + Send + Sync + Add<Output = T> + Mul<f64, Output = T>>(
    y: &mut Vec<T>,
    a: f64,
    f: &[T],
    b: f64,
    x: &[T],
) {
    if y.len() != f.len() {
        y.clear();
        y.extend_from_slice(f);
    }
    y.par_iter_mut()
        .with_min_len(MIN_CHUNK)
        .zip(f.par_iter().zip(x))
        .for_each(|(y, (&f, &x))| *y = f * a + x * b);
}

/// A particle state: the struct of displacement `u`, velocity `v` and the further fields
/// given, and its `OdeState`, `Clone` (whose `clone_from` copies into the buffers there
/// are) and empty `Default`. Every field has a rate of its own: RK stages combine every
/// field; the leapfrog drift moves u with the state's own v and the other fields with
/// their rates.
macro_rules! particle_state {
    (
        $(#[$meta:meta])*
        pub struct $state:ident {
            $($(#[$field_meta:meta])* pub $field:ident: $type:ty,)*
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug)]
        pub struct $state<D: Dim> {
            /// Displacement u = x − X.
            pub u: Vec<D::V>,
            /// Velocity v.
            pub v: Vec<D::V>,
            $($(#[$field_meta])* pub $field: $type,)*
        }

        impl<D: Dim> Default for $state<D> {
            fn default() -> Self {
                Self {
                    u: Vec::new(),
                    v: Vec::new(),
                    $($field: Vec::new(),)*
                }
            }
        }

        impl<D: Dim> Clone for $state<D> {
            fn clone(&self) -> Self {
                Self {
                    u: self.u.clone(),
                    v: self.v.clone(),
                    $($field: self.$field.clone(),)*
                }
            }

            /// Field by field into the buffers there are: the integrators' stage copies
            /// allocate nothing.
            fn clone_from(&mut self, source: &Self) {
                self.u.clone_from(&source.u);
                self.v.clone_from(&source.v);
                $(self.$field.clone_from(&source.$field);)*
            }
        }

        impl<D: Dim> crate::core::integrate::OdeState for $state<D> {
            fn axpy(&mut self, a: f64, r: &Self) {
                crate::core::parallel::axpy(&mut self.u, a, &r.u);
                crate::core::parallel::axpy(&mut self.v, a, &r.v);
                $(crate::core::parallel::axpy(&mut self.$field, a, &r.$field);)*
            }

            fn blend(&mut self, a: f64, b: f64, o: &Self) {
                crate::core::parallel::blend(&mut self.u, a, b, &o.u);
                crate::core::parallel::blend(&mut self.v, a, b, &o.v);
                $(crate::core::parallel::blend(&mut self.$field, a, b, &o.$field);)*
            }

            fn blend_from(&mut self, a: f64, f: &Self, b: f64, o: &Self) {
                crate::core::parallel::blend_from(&mut self.u, a, &f.u, b, &o.u);
                crate::core::parallel::blend_from(&mut self.v, a, &f.v, b, &o.v);
                $(crate::core::parallel::blend_from(
                    &mut self.$field,
                    a,
                    &f.$field,
                    b,
                    &o.$field,
                );)*
            }

            fn kick(&mut self, h: f64, r: &Self) {
                crate::core::parallel::axpy(&mut self.v, h, &r.v);
            }

            fn drift(&mut self, h: f64, r: &Self) {
                crate::core::parallel::axpy(&mut self.u, h, &self.v);
                $(crate::core::parallel::axpy(&mut self.$field, h, &r.$field);)*
            }

            fn save(&self, out: &mut Vec<f64>) {
                crate::core::parallel::save_field(&self.u, out);
                crate::core::parallel::save_field(&self.v, out);
                $(crate::core::parallel::save_field(&self.$field, out);)*
            }

            fn load(&mut self, words: &mut &[f64]) -> Result<(), String> {
                crate::core::parallel::load_field(&mut self.u, "u", words)?;
                crate::core::parallel::load_field(&mut self.v, "v", words)?;
                $(crate::core::parallel::load_field(
                    &mut self.$field,
                    stringify!($field),
                    words,
                )?;)*
                Ok(())
            }
        }

        impl<D: Dim> crate::core::parallel::ParticleRows for $state<D> {
            fn rows(&self, ids: &[u32], out: &mut Vec<f64>) {
                for &i in ids {
                    crate::core::parallel::put_row(&self.u, i, out);
                    crate::core::parallel::put_row(&self.v, i, out);
                    $(crate::core::parallel::put_row(&self.$field, i, out);)*
                }
            }

            fn set_rows<'w>(&mut self, ids: &[u32], mut words: &'w [f64]) -> &'w [f64] {
                for &i in ids {
                    crate::core::parallel::take_row(&mut self.u, i, &mut words);
                    crate::core::parallel::take_row(&mut self.v, i, &mut words);
                    $(crate::core::parallel::take_row(&mut self.$field, i, &mut words);)*
                }
                words
            }

            fn zeros_like(&self, n: usize) -> Self {
                Self {
                    u: crate::core::parallel::zeros_like(&self.u, n),
                    v: crate::core::parallel::zeros_like(&self.v, n),
                    $($field: crate::core::parallel::zeros_like(&self.$field, n),)*
                }
            }
        }
    };
}
pub(crate) use particle_state;

/// A state whose fields hold one value per particle each, or none: what a distributed
/// run moves between ranks particle by particle ([`particle_state!`] implements it).
pub trait ParticleRows: Sized {
    /// Appends the row of each particle of `ids`: its value of every field that holds
    /// values, in field order, exactly.
    fn rows(&self, ids: &[u32], out: &mut Vec<f64>);
    /// Overwrites the particles `ids` with the rows [`Self::rows`] wrote at the front of
    /// `words`; returns the words after them.
    fn set_rows<'w>(&mut self, ids: &[u32], words: &'w [f64]) -> &'w [f64];
    /// A state of n particles, zero, whose fields hold values where this one's do.
    fn zeros_like(&self, n: usize) -> Self;
}

/// Appends particle i's value of a field that holds values.
pub(crate) fn put_row<T: Words>(field: &[T], i: u32, out: &mut Vec<f64>) {
    if !field.is_empty() {
        field[i as usize].put(out);
    }
}

/// Reads particle i's value of a field that holds values from the front of `words`.
pub(crate) fn take_row<T: Words>(field: &mut [T], i: u32, words: &mut &[f64]) {
    if !field.is_empty() {
        field[i as usize] = T::take(words);
        *words = &words[T::LEN..];
    }
}

/// n zeros where `field` holds values, none where it holds none.
pub(crate) fn zeros_like<T: Words>(field: &[T], n: usize) -> Vec<T> {
    if field.is_empty() {
        Vec::new()
    } else {
        vec![T::take(&[0.0; 9][..T::LEN]); n]
    }
}

/// Appends a field for a checkpoint: its length, then its values.
pub(crate) fn save_field<T: Words>(field: &[T], out: &mut Vec<f64>) {
    out.push(field.len() as f64);
    for x in field {
        x.put(out);
    }
}

/// Reads one word, `name`, from the front of a checkpoint's words.
pub(crate) fn load_word(words: &mut &[f64], name: &str) -> Result<f64, String> {
    let (&word, rest) = words
        .split_first()
        .ok_or_else(|| format!("the checkpoint ends before {name}"))?;
    *words = rest;
    Ok(word)
}

/// A count stored as an f64 word of a checkpoint, if it is one: whole, not negative,
/// and exact in an f64.
pub fn whole_word(x: f64) -> Option<u64> {
    (x >= 0.0 && x.fract() == 0.0 && x < 2f64.powi(53)).then_some(x as u64)
}

/// Reads a field [`save_field`] wrote into `field`, which must have its length.
pub(crate) fn load_field<T: Words>(
    field: &mut [T],
    name: &str,
    words: &mut &[f64],
) -> Result<(), String> {
    let (&len, rest) = words
        .split_first()
        .ok_or_else(|| format!("the checkpoint ends before the field {name}"))?;
    if len != field.len() as f64 || rest.len() < field.len() * T::LEN {
        return Err(format!(
            "the field {name} holds {len} values in the checkpoint and {} in this run",
            field.len()
        ));
    }
    for (x, w) in field.iter_mut().zip(rest.chunks_exact(T::LEN)) {
        *x = T::take(w);
    }
    *words = &rest[field.len() * T::LEN..];
    Ok(())
}
