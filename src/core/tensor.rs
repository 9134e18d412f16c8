//! Dimension abstraction: small vectors and second-order tensors in 2D or 3D.
//!
//! Every numerical routine is generic over [`Dim`], so a 2D scene works on
//! `DVec2`/`DMat2` and never pays for 3D tensor algebra. [`Linear`] names what vectors and
//! tensors share (a real vector space stored as f64 words); `glam_dim!` writes the members
//! of `Dim` that read alike in 2D and 3D once.

use glam::{DMat2, DMat3, DVec2, DVec3};
use serde::{Deserialize, Serialize};
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// What vectors and tensors alike are: elements of a real vector space (sums, differences,
/// scaling by f64), copied freely and stored as f64 words.
pub trait Linear:
    Copy
    + Send
    + Sync
    + Debug
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<f64, Output = Self>
    + AddAssign
    + SubAssign
    + Words
{
}

impl Linear for f64 {}
impl Linear for DVec2 {}
impl Linear for DVec3 {}
impl Linear for DMat2 {}
impl Linear for DMat3 {}

/// Space dimension: the vector and tensor types and the operations the methods need.
pub trait Dim: Copy + Send + Sync + Debug + 'static {
    /// Number of spatial components (1, 2 or 3).
    const N: usize;
    /// Position, velocity, acceleration.
    type V: Linear + Default + Neg<Output = Self::V>;
    /// Second-order tensor (F, P, σ, correction matrices).
    type T: Linear + Mul<Self::V, Output = Self::V> + Mul<Self::T, Output = Self::T>;

    fn zero() -> Self::V;
    fn zero_t() -> Self::T;
    fn identity() -> Self::T;
    fn dot(a: Self::V, b: Self::V) -> f64;
    /// (a ⊗ b)_kl = a_k b_l.
    fn outer(a: Self::V, b: Self::V) -> Self::T;
    fn transpose(t: Self::T) -> Self::T;
    fn det(t: Self::T) -> f64;
    fn inverse(t: Self::T) -> Self::T;
    fn trace(t: Self::T) -> f64;
    /// Double contraction A : B = Σ_kl A_kl B_kl.
    fn ddot(a: Self::T, b: Self::T) -> f64;
    /// Component k of a vector.
    fn comp(v: Self::V, k: usize) -> f64;
    /// Vector from the first N entries of a slice.
    fn from_slice(s: &[f64]) -> Self::V;
    /// Vector padded to three components (2D: z = 0).
    fn to3(v: Self::V) -> [f64; 3];
    /// Tensor padded to 3×3 (2D: zeros in the third row and column), row-major.
    fn to3x3(t: Self::T) -> [[f64; 3]; 3];
    /// Angular momentum of a point mass, r × p (2D: the out-of-plane component in z).
    fn cross3(r: Self::V, p: Self::V) -> [f64; 3];
    /// Cofactor cof A = det(A) A⁻ᵀ, defined for singular A too.
    fn cof(a: Self::T) -> Self::T;
    /// Rate of the cofactor, d(cof F)/dt = F × Ḟ with the tensor cross product
    /// (A × B)_iI = ε_ijk ε_IJK A_jJ B_kK (seed 003 eq 3). In 2D plane strain (F_zz = 1,
    /// Ḟ_zz = 0) the in-plane block of F × Ḟ is cof Ḟ.
    fn cof_rate(f: Self::T, f_dot: Self::T) -> Self::T;
    /// Tensor entry T_kl.
    fn entry(t: Self::T, k: usize, l: usize) -> f64 {
        Self::to3x3(t)[k][l]
    }
    fn norm2(v: Self::V) -> f64 {
        Self::dot(v, v)
    }
    fn is_finite_v(v: Self::V) -> bool {
        Self::to3(v).iter().all(|c| c.is_finite())
    }
    fn is_finite_t(t: Self::T) -> bool {
        Self::to3x3(t).iter().flatten().all(|c| c.is_finite())
    }
}

/// A value a checkpoint stores exactly, as `LEN` f64 words (tensors column by column).
pub trait Words: Copy {
    const LEN: usize;
    fn put(self, out: &mut Vec<f64>);
    /// The value of the first `LEN` words.
    fn take(words: &[f64]) -> Self;
}

impl Words for f64 {
    const LEN: usize = 1;
    fn put(self, out: &mut Vec<f64>) {
        out.push(self);
    }
    fn take(words: &[f64]) -> Self {
        words[0]
    }
}

macro_rules! glam_words {
    ($($t:ty: $len:expr, $to:ident, $from:ident;)*) => {$(
        impl Words for $t {
            const LEN: usize = $len;
            fn put(self, out: &mut Vec<f64>) {
                out.extend(self.$to());
            }
            fn take(words: &[f64]) -> Self {
                <$t>::$from(&words[..$len])
            }
        }
    )*};
}

glam_words! {
    DVec2: 2, to_array, from_slice;
    DVec3: 3, to_array, from_slice;
    DMat2: 4, to_cols_array, from_cols_slice;
    DMat3: 9, to_cols_array, from_cols_slice;
}

/// One dimension: vectors and tensors are scalars. For the 1D gradient tests of seed 002
/// §4.1; no method runs in 1D. The kernels keep their 3D normalisation σ_d here, which
/// the corrected kernels (Shepard, RKPM, CGCK) divide out.
#[derive(Clone, Copy, Debug)]
pub struct D1;

/// Two dimensions (plane strain).
#[derive(Clone, Copy, Debug)]
pub struct D2;

/// Three dimensions.
#[derive(Clone, Copy, Debug)]
pub struct D3;

impl Dim for D1 {
    const N: usize = 1;
    type V = f64;
    type T = f64;

    fn zero() -> f64 {
        0.0
    }
    fn zero_t() -> f64 {
        0.0
    }
    fn identity() -> f64 {
        1.0
    }
    fn dot(a: f64, b: f64) -> f64 {
        a * b
    }
    fn outer(a: f64, b: f64) -> f64 {
        a * b
    }
    fn transpose(t: f64) -> f64 {
        t
    }
    fn det(t: f64) -> f64 {
        t
    }
    fn inverse(t: f64) -> f64 {
        1.0 / t
    }
    fn trace(t: f64) -> f64 {
        t
    }
    fn ddot(a: f64, b: f64) -> f64 {
        a * b
    }
    fn comp(v: f64, _k: usize) -> f64 {
        v
    }
    fn from_slice(s: &[f64]) -> f64 {
        s[0]
    }
    fn to3(v: f64) -> [f64; 3] {
        [v, 0.0, 0.0]
    }
    fn to3x3(t: f64) -> [[f64; 3]; 3] {
        [[t, 0.0, 0.0], [0.0; 3], [0.0; 3]]
    }
    fn cross3(_r: f64, _p: f64) -> [f64; 3] {
        [0.0; 3]
    }
    /// cof F = det F F⁻ᵀ = 1.
    fn cof(_a: f64) -> f64 {
        1.0
    }
    fn cof_rate(_f: f64, _f_dot: f64) -> f64 {
        0.0
    }
}

/// `Dim` on glam's vectors and matrices: the members that read alike in 2D and 3D once,
/// the rest (`$own`) per dimension.
macro_rules! glam_dim {
    ($d:ty, $n:expr, $v:ty, $t:ty, { $($own:tt)* }) => {
        impl Dim for $d {
            const N: usize = $n;
            type V = $v;
            type T = $t;

            #[inline]
            fn zero() -> $v {
                <$v>::ZERO
            }
            #[inline]
            fn zero_t() -> $t {
                <$t>::ZERO
            }
            #[inline]
            fn identity() -> $t {
                <$t>::IDENTITY
            }
            #[inline]
            fn dot(a: $v, b: $v) -> f64 {
                a.dot(b)
            }
            #[inline]
            fn transpose(t: $t) -> $t {
                t.transpose()
            }
            #[inline]
            fn det(t: $t) -> f64 {
                t.determinant()
            }
            #[inline]
            fn inverse(t: $t) -> $t {
                t.inverse()
            }
            #[inline]
            fn comp(v: $v, k: usize) -> f64 {
                v[k]
            }

            $($own)*
        }
    };
}

glam_dim!(D2, 2, DVec2, DMat2, {
    #[inline]
    fn outer(a: DVec2, b: DVec2) -> DMat2 {
        // glam stores columns: column l is a * b_l.
        DMat2::from_cols(a * b.x, a * b.y)
    }
    #[inline]
    fn trace(t: DMat2) -> f64 {
        t.x_axis.x + t.y_axis.y
    }
    #[inline]
    fn ddot(a: DMat2, b: DMat2) -> f64 {
        a.x_axis.dot(b.x_axis) + a.y_axis.dot(b.y_axis)
    }
    fn from_slice(s: &[f64]) -> DVec2 {
        DVec2::new(s[0], s[1])
    }
    #[inline]
    fn to3(v: DVec2) -> [f64; 3] {
        [v.x, v.y, 0.0]
    }
    fn to3x3(t: DMat2) -> [[f64; 3]; 3] {
        [
            [t.x_axis.x, t.y_axis.x, 0.0],
            [t.x_axis.y, t.y_axis.y, 0.0],
            [0.0, 0.0, 0.0],
        ]
    }
    #[inline]
    fn cross3(r: DVec2, p: DVec2) -> [f64; 3] {
        [0.0, 0.0, r.perp_dot(p)]
    }
    #[inline]
    fn cof(a: DMat2) -> DMat2 {
        DMat2::from_cols(
            DVec2::new(a.y_axis.y, -a.y_axis.x),
            DVec2::new(-a.x_axis.y, a.x_axis.x),
        )
    }
    #[inline]
    fn cof_rate(_f: DMat2, f_dot: DMat2) -> DMat2 {
        Self::cof(f_dot)
    }
});

glam_dim!(D3, 3, DVec3, DMat3, {
    #[inline]
    fn outer(a: DVec3, b: DVec3) -> DMat3 {
        DMat3::from_cols(a * b.x, a * b.y, a * b.z)
    }
    #[inline]
    fn trace(t: DMat3) -> f64 {
        t.x_axis.x + t.y_axis.y + t.z_axis.z
    }
    #[inline]
    fn ddot(a: DMat3, b: DMat3) -> f64 {
        a.x_axis.dot(b.x_axis) + a.y_axis.dot(b.y_axis) + a.z_axis.dot(b.z_axis)
    }
    fn from_slice(s: &[f64]) -> DVec3 {
        DVec3::new(s[0], s[1], s[2])
    }
    #[inline]
    fn to3(v: DVec3) -> [f64; 3] {
        v.to_array()
    }
    fn to3x3(t: DMat3) -> [[f64; 3]; 3] {
        let c = t.to_cols_array_2d();
        [
            [c[0][0], c[1][0], c[2][0]],
            [c[0][1], c[1][1], c[2][1]],
            [c[0][2], c[1][2], c[2][2]],
        ]
    }
    #[inline]
    fn cross3(r: DVec3, p: DVec3) -> [f64; 3] {
        r.cross(p).to_array()
    }
    #[inline]
    fn cof(a: DMat3) -> DMat3 {
        Self::cof_rate(a, a) * 0.5
    }
    /// (A × B)_iI = A_jJ B_kK − A_jK B_kJ − A_kJ B_jK + A_kK B_jJ with (i, j, k) and
    /// (I, J, K) cyclic.
    fn cof_rate(f: DMat3, f_dot: DMat3) -> DMat3 {
        let (a, b) = (f.to_cols_array_2d(), f_dot.to_cols_array_2d());
        // Column-major storage: a[col][row] = A_row,col.
        let e = |m: &[[f64; 3]; 3], r: usize, c: usize| m[c][r];
        let entry = |i: usize, ii: usize| {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            let (jj, kk) = ((ii + 1) % 3, (ii + 2) % 3);
            e(&a, j, jj) * e(&b, k, kk) - e(&a, j, kk) * e(&b, k, jj) - e(&a, k, jj) * e(&b, j, kk)
                + e(&a, k, kk) * e(&b, j, jj)
        };
        DMat3::from_cols_array_2d(&std::array::from_fn(|col| {
            std::array::from_fn(|row| entry(row, col))
        }))
    }
});

/// The smallest principal stretch squared of F: the smallest eigenvalue of C = FᵀF, in
/// closed form (2D), or by the trigonometric solution of the characteristic cubic (3D).
pub fn smallest_stretch_squared<D: Dim>(f: D::T) -> f64 {
    let c = D::transpose(f) * f;
    let e = |k: usize, l: usize| D::entry(c, k, l);
    let q = D::trace(c) / D::N as f64;
    if D::N == 2 {
        let r = (0.25 * (e(0, 0) - e(1, 1)).powi(2) + e(0, 1).powi(2)).sqrt();
        return q - r;
    }
    let off = e(0, 1).powi(2) + e(0, 2).powi(2) + e(1, 2).powi(2);
    let p = (((e(0, 0) - q).powi(2) + (e(1, 1) - q).powi(2) + (e(2, 2) - q).powi(2) + 2.0 * off)
        / 6.0)
        .sqrt();
    if p == 0.0 {
        return q;
    }
    // B = (C − qI)/p has eigenvalues 2 cos(φ + 2πk/3), φ = acos(det B / 2)/3.
    let b = (c - D::identity() * q) * (1.0 / p);
    let phi = (0.5 * D::det(b)).clamp(-1.0, 1.0).acos() / 3.0;
    q + 2.0 * p * (phi + 2.0 * std::f64::consts::FRAC_PI_3).cos()
}

/// A coordinate axis, as case files name it (`x`, `y`, `z`).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub fn index(self) -> usize {
        self as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smallest_stretch_squared_of_a_rotated_stretch() {
        // F = R diag(λ) has C = diag(λ²); the rotation must not change the answer
        // (round-off of the cubic's trigonometric solution: 1e-12).
        let r3 = DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0);
        for l in [
            [2.0, 0.5, 1.5],
            [0.7, 0.7, 3.0],
            [1.0, 1.0, 1.0],
            [4.0, 0.2, 0.2],
        ] {
            let f = r3 * DMat3::from_diagonal(DVec3::from_array(l));
            let min = l.iter().fold(f64::INFINITY, |m, &x| m.min(x * x));
            assert!(
                (smallest_stretch_squared::<D3>(f) - min).abs() < 1e-12,
                "{l:?}"
            );
        }
        let r2 = DMat2::from_angle(0.7);
        for l in [[2.0, 0.5], [0.3, 0.3], [1.2, 3.0]] {
            let f = r2 * DMat2::from_diagonal(DVec2::from_array(l));
            let min = l.iter().fold(f64::INFINITY, |m, &x| m.min(x * x));
            assert!(
                (smallest_stretch_squared::<D2>(f) - min).abs() < 1e-12,
                "{l:?}"
            );
        }
    }

    #[test]
    fn cofactor_is_det_times_inverse_transpose_and_cof_rate_its_derivative() {
        let f3 = DMat3::from_cols_array(&[1.1, 0.2, -0.3, 0.4, 0.9, 0.1, -0.2, 0.3, 1.2]);
        let l3 = DMat3::from_cols_array(&[0.3, -0.7, 0.2, 0.5, 0.1, -0.4, 0.6, 0.8, -0.9]);
        let f2 = DMat2::from_cols_array(&[1.1, 0.2, -0.3, 0.9]);
        let l2 = DMat2::from_cols_array(&[0.3, -0.7, 0.2, 0.5]);
        fn check<D: Dim>(f: D::T, l: D::T) {
            let exact = D::transpose(D::inverse(f)) * D::det(f);
            let e = D::cof(f) - exact;
            assert!(D::ddot(e, e).sqrt() < 1e-14);
            // Central difference of cof(F + εL): cof is quadratic, so exact to round-off.
            let eps = 1e-3;
            let fd = (D::cof(f + l * eps) - D::cof(f - l * eps)) * (0.5 / eps);
            let e = D::cof_rate(f, l) - fd;
            assert!(D::ddot(e, e).sqrt() < 1e-11, "{e:?}");
        }
        check::<D3>(f3, l3);
        check::<D2>(f2, l2);
    }

    #[test]
    fn outer_product_is_row_by_column() {
        let t = D2::outer(DVec2::new(1.0, 2.0), DVec2::new(3.0, 5.0));
        assert_eq!(D2::entry(t, 0, 1), 5.0);
        assert_eq!(D2::entry(t, 1, 0), 6.0);
        let t3 = D3::outer(DVec3::new(1.0, 2.0, 3.0), DVec3::new(7.0, 11.0, 13.0));
        assert_eq!(D3::entry(t3, 2, 0), 21.0);
        assert_eq!(D3::entry(t3, 0, 2), 13.0);
        // (a ⊗ b) c = a (b · c)
        let c = DVec3::new(0.5, -1.0, 2.0);
        assert_eq!(
            t3 * c,
            DVec3::new(1.0, 2.0, 3.0) * (7.0 * 0.5 - 11.0 + 26.0)
        );
    }
}
